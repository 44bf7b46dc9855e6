// The task's workspace in three.js: the tracker, the table, the object, the place rings (a send's or
// a handover's zone: two crossed rings) and the rendered (god-object) hand, in the tracker's frame
// (metres; x right, y up, z toward the participant), exactly as the session's messages describe them.
//
// Drawn cheaply, for a page that must keep up on a computer without a GPU: the light (from the
// sky and the sun) is worked out per vertex, so a pixel costs what a plain colour costs (per-pixel
// lighting, three.js's standard material, took 3 to 5 times as long in software); every phalanx
// of both hands is one instanced capsule mesh and the place rings another (a software rasteriser
// spends about half a millisecond on each draw call); nothing is allocated per frame.
import * as THREE from "three";

const UP = new THREE.Vector3(0, 1, 0);
const SLOTS = 40;
const TRACKER_SIZE = [0.08, 0.011, 0.03];
const RING = { tube: 0.003, radialSegments: 4, tubularSegments: 48 };
const CAPSULE = { capSegments: 2, radialSegments: 8 };

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

/** The light on a surface of normal n (world frame): BASE + SKY n.y + SUN max(n . toward the sun, 0),
 *  multiplying its colour. */
const LIGHT = { base: 0.6, sky: 0.2, sun: 0.45, toward: new THREE.Vector3(0.3, 1.0, 0.8).normalize() };
const LIGHT_VERTEX = `
  vec3 litNormal = normal;
  #ifdef USE_INSTANCING
    litNormal = mat3(instanceMatrix) * litNormal;
  #endif
  litNormal = normalize(mat3(modelMatrix) * litNormal);
  vLight = ${LIGHT.base.toFixed(3)} + ${LIGHT.sky.toFixed(3)} * litNormal.y +
           ${LIGHT.sun.toFixed(3)} * max(dot(litNormal, towardSun), 0.0);
`;

/** A unit-radius capsule whose cylinder ends at y = +-1: the vertex shader (`stretch`) moves each
 *  end out to the phalanx's half length (per instance, in radii), so a capsule of any length keeps
 *  round ends under the instance's uniform scale by the radius. */
function capsuleGeometry() {
  const geometry = new THREE.CapsuleGeometry(1, 2, CAPSULE.capSegments, CAPSULE.radialSegments);
  geometry.setAttribute("halfLength", new THREE.InstancedBufferAttribute(new Float32Array(SLOTS), 1));
  return geometry;
}

/** A surface of `color`, lit per vertex; a phalanx capsule with `stretch`. */
function material(color, stretch = false) {
  const surface = new THREE.MeshBasicMaterial({ color });
  surface.onBeforeCompile = (shader) => {
    shader.uniforms.towardSun = { value: LIGHT.toward };
    shader.vertexShader = shader.vertexShader
      .replace("#include <common>", "#include <common>\nuniform vec3 towardSun;\nvarying float vLight;" +
               (stretch ? "\nattribute float halfLength;" : ""))
      .replace("#include <begin_vertex>", `${LIGHT_VERTEX}#include <begin_vertex>` +
               (stretch ? "\ntransformed.y += sign(transformed.y) * (halfLength - 1.0);" : ""));
    shader.fragmentShader = shader.fragmentShader
      .replace("#include <common>", "#include <common>\nvarying float vLight;")
      .replace("#include <color_fragment>", "#include <color_fragment>\n  diffuseColor.rgb *= vLight;");
  };
  surface.customProgramCacheKey = () => `lit per vertex${stretch ? ", stretched" : ""}`;
  return surface;
}

export class Workspace {
  constructor() {
    this.root = new THREE.Group();
    this.colours = null;
    this.layout = null;
    this.object = null;
    this.rings = null;
    this.fixed = [];
    this.root.add(new THREE.Mesh(new THREE.BoxGeometry(...TRACKER_SIZE), material(0x28282d)));
    this.phalanges = new THREE.InstancedMesh(capsuleGeometry(), material(0xffffff, true), SLOTS);
    this.phalanges.setColorAt(0, new THREE.Color());  // instance colours from the first compile on
    this.phalanges.count = 0;
    this.phalanges.frustumCulled = false;
    this.root.add(this.phalanges);
    this._halfLength = this.phalanges.geometry.getAttribute("halfLength");
    this._matrix = new THREE.Matrix4();
    this._q = new THREE.Quaternion();
    this._a = new THREE.Vector3();
    this._b = new THREE.Vector3();
    this._d = new THREE.Vector3();
    this._s = new THREE.Vector3();
  }

  /** A new task: rebuild what differs between tasks (the object, the places or the zone, the table). */
  setScene(scene) {
    for (const thing of [this.object, this.rings, ...this.fixed]) {
      if (thing) this.root.remove(thing);
    }
    this.layout = scene;
    this.colours = Object.fromEntries(Object.entries(scene.palette).map(([name, rgb]) => [name, colour(rgb)]));
    const geometry = scene.surface ? meshGeometry(scene.surface)
      : scene.shape === "sphere" ? new THREE.SphereGeometry(scene.size[0] / 2, 32, 24)
      : new THREE.BoxGeometry(...scene.size);
    this.object = new THREE.Mesh(geometry, material(this.colours.object));
    this.object.position.set(...scene.start);
    this.root.add(this.object);
    this.rings = new THREE.InstancedMesh(
      new THREE.TorusGeometry(scene.place_radius, RING.tube, RING.radialSegments, RING.tubularSegments),
      new THREE.MeshBasicMaterial(), scene.places.length);
    scene.places.forEach((place, k) => {
      this.rings.setMatrixAt(k, this._matrix.makeTranslation(...place));
      this.rings.setColorAt(k, this.colours.pending);
    });
    this.rings.frustumCulled = false;
    this.root.add(this.rings);
    this.fixed = [];
    if (scene.target) {
      const ring = new THREE.TorusGeometry(scene.target.radius, RING.tube, RING.radialSegments, RING.tubularSegments);
      const zone = new THREE.InstancedMesh(ring, new THREE.MeshBasicMaterial({ color: this.colours.target }), 2);
      zone.setMatrixAt(0, this._matrix.makeTranslation(...scene.target.centre));
      zone.setMatrixAt(1, this._matrix.makeRotationY(Math.PI / 2).setPosition(...scene.target.centre));
      zone.frustumCulled = false;
      this.root.add(zone);
      this.fixed.push(zone);
    }
    if (scene.table) {
      const table = new THREE.Mesh(new THREE.BoxGeometry(...scene.table.size), material(this.colours.table));
      const [x, y, z] = scene.table.centre;
      table.position.set(x, y - scene.table.size[1] / 2, z);
      this.root.add(table);
      this.fixed.push(table);
    }
    this.phalanges.count = 0;
  }

  /** Draw one frame: the object's pose, each place's state, the rendered hand and its highlight. */
  setFrame(frame) {
    if (!this.layout) return;
    const pose = frame.object;
    this.object.position.set(pose[0], pose[1], pose[2]);
    this.object.quaternion.set(pose[4], pose[5], pose[6], pose[3]);
    for (let k = 0; k < this.rings.count; k++) {
      const state = k < frame.place ? "done" : k === frame.place ? (frame.lit ? "lit" : "next") : "pending";
      this.rings.setColorAt(k, this.colours[state]);
    }
    if (this.rings.instanceColor) this.rings.instanceColor.needsUpdate = true;  // (none: a task without places)
    const { rendered, highlight } = this.colours;
    let n = 0;
    for (const hand of frame.hands) {
      for (let k = 0; k < hand.radius.length && n < SLOTS; k++) {
        const r = hand.radius[k];
        this._a.fromArray(hand.start[k]);
        this._b.fromArray(hand.end[k]);
        this._d.subVectors(this._b, this._a);
        const length = this._d.length();
        this._q.setFromUnitVectors(UP, length > 1e-9 ? this._d.normalize() : UP);
        this._s.set(r, r, r);
        this._d.addVectors(this._a, this._b).multiplyScalar(0.5);
        this._matrix.compose(this._d, this._q, this._s);
        this.phalanges.setMatrixAt(n, this._matrix);
        this.phalanges.setColorAt(n, hand.touching[k] ? highlight : rendered);
        this._halfLength.array[n] = length / (2 * r);
        n += 1;
      }
    }
    this.phalanges.count = n;
    this.phalanges.instanceMatrix.needsUpdate = true;
    if (this.phalanges.instanceColor) this.phalanges.instanceColor.needsUpdate = true;  // (none before a hand)
    this._halfLength.needsUpdate = true;
  }
}
