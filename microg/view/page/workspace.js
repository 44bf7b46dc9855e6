// The task's workspace in three.js: the tracker, the table, the object, the place rings and the
// rendered (god-object) hand, in the tracker's frame (metres; x right, y up, z toward the
// participant), exactly as the session's messages describe them.
import * as THREE from "three";

const UP = new THREE.Vector3(0, 1, 0);
const SLOTS = 40;
const TRACKER_SIZE = [0.08, 0.011, 0.03];
const RING_TUBE = 0.003;

function colour(rgb) {
  return new THREE.Color(rgb[0] / 255, rgb[1] / 255, rgb[2] / 255);
}

/** A mesh object's surface (flat vertex and triangle lists, body frame) as a geometry, flat-shaded. */
function meshGeometry(surface) {
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute("position", new THREE.Float32BufferAttribute(surface.vertices, 3));
  geometry.setIndex(surface.faces);
  const flat = geometry.toNonIndexed();
  flat.computeVertexNormals();
  return flat;
}

export class Workspace {
  constructor() {
    this.root = new THREE.Group();
    this.palette = null;
    this.layout = null;
    this.object = null;
    this.rings = [];
    this.fixed = [];
    this.root.add(new THREE.HemisphereLight(0xffffff, 0x404050, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(0.3, 1.0, 0.8);
    this.root.add(sun);
    const tracker = new THREE.Mesh(new THREE.BoxGeometry(...TRACKER_SIZE),
                                   new THREE.MeshStandardMaterial({ color: 0x28282d }));
    this.root.add(tracker);
    const material = new THREE.MeshStandardMaterial({ color: 0xffffff, roughness: 0.6 });
    this.bones = new THREE.InstancedMesh(new THREE.CylinderGeometry(1, 1, 1, 16), material, SLOTS);
    this.ends = new THREE.InstancedMesh(new THREE.SphereGeometry(1, 16, 12), material, 2 * SLOTS);
    for (const mesh of [this.bones, this.ends]) {
      mesh.count = 0;
      mesh.frustumCulled = false;
      this.root.add(mesh);
    }
    this._matrix = new THREE.Matrix4();
    this._q = new THREE.Quaternion();
    this._a = new THREE.Vector3();
    this._b = new THREE.Vector3();
    this._d = new THREE.Vector3();
    this._s = new THREE.Vector3();
  }

  /** A new task: rebuild what differs between tasks (the object, the places, the table). */
  setScene(scene) {
    for (const thing of [this.object, ...this.rings, ...this.fixed]) {
      if (thing) this.root.remove(thing);
    }
    this.layout = scene;
    this.palette = scene.palette;
    const material = new THREE.MeshStandardMaterial({ color: colour(this.palette.object), roughness: 0.7 });
    const geometry = scene.surface ? meshGeometry(scene.surface)
      : scene.shape === "sphere" ? new THREE.SphereGeometry(scene.size[0] / 2, 32, 24)
      : new THREE.BoxGeometry(...scene.size);
    this.object = new THREE.Mesh(geometry, material);
    this.object.position.set(...scene.start);
    this.root.add(this.object);
    this.rings = scene.places.map((place) => {
      const ring = new THREE.Mesh(new THREE.TorusGeometry(scene.place_radius, RING_TUBE, 8, 64),
                                  new THREE.MeshBasicMaterial({ color: colour(this.palette.pending) }));
      ring.position.set(...place);
      this.root.add(ring);
      return ring;
    });
    this.fixed = [];
    if (scene.table) {
      const table = new THREE.Mesh(new THREE.BoxGeometry(...scene.table.size),
                                   new THREE.MeshStandardMaterial({ color: colour(this.palette.table) }));
      const [x, y, z] = scene.table.centre;
      table.position.set(x, y - scene.table.size[1] / 2, z);
      this.root.add(table);
      this.fixed.push(table);
    }
    this.bones.count = 0;
    this.ends.count = 0;
  }

  /** Draw one frame: the object's pose, each place's state, the rendered hand and its highlight. */
  setFrame(frame) {
    if (!this.layout) return;
    const [px, py, pz, qw, qx, qy, qz] = frame.object;
    this.object.position.set(px, py, pz);
    this.object.quaternion.set(qx, qy, qz, qw);
    this.rings.forEach((ring, k) => {
      const state = k < frame.place ? "done" : k === frame.place ? (frame.lit ? "lit" : "next") : "pending";
      ring.material.color.copy(colour(this.palette[state]));
    });
    const base = colour(this.palette.rendered);
    const highlight = colour(this.palette.highlight);
    let n = 0;
    for (const hand of frame.hands) {
      for (let k = 0; k < hand.radius.length; k++) {
        const r = hand.radius[k];
        this._a.fromArray(hand.start[k]);
        this._b.fromArray(hand.end[k]);
        this._d.subVectors(this._b, this._a);
        const length = this._d.length();
        this._q.setFromUnitVectors(UP, length > 1e-9 ? this._d.normalize() : UP);
        this._s.set(r, length, r);
        this._d.addVectors(this._a, this._b).multiplyScalar(0.5);
        this._matrix.compose(this._d, this._q, this._s);
        this.bones.setMatrixAt(n, this._matrix);
        const tint = hand.touching[k] ? highlight : base;
        this.bones.setColorAt(n, tint);
        this._s.set(r, r, r);
        this._q.identity();
        this._matrix.compose(this._a, this._q, this._s);
        this.ends.setMatrixAt(2 * n, this._matrix);
        this._matrix.compose(this._b, this._q, this._s);
        this.ends.setMatrixAt(2 * n + 1, this._matrix);
        this.ends.setColorAt(2 * n, tint);
        this.ends.setColorAt(2 * n + 1, tint);
        n += 1;
      }
    }
    this.bones.count = n;
    this.ends.count = 2 * n;
    for (const mesh of [this.bones, this.ends]) {
      mesh.instanceMatrix.needsUpdate = true;
      if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
    }
  }
}
