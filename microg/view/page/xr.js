// Headset mode (WebXR): where the browser offers immersive sessions, an "Enter mixed reality"
// button opens one (immersive-ar with passthrough where available, immersive-vr otherwise), with
// hand tracking. A placement step anchors the workspace in the headset's space: the participant
// holds a hand flat, palm down, where the table should be, and pinches; the palm then marks the
// session's `mark` point (the table top's centre) and the hand's forward direction the tracker's
// -z. The anchor (a 4 x 4 matrix, row-major, from the workspace to the XR reference space) goes
// to the session, the workspace (workspace.js) is drawn through it, and every XR frame the 25
// joints of each tracked hand are read, taken into the workspace frame and streamed to the
// session (microg.hands.webxr). The timeline and the questionnaire are drawn in 3D: a board
// behind the workspace and a panel within reach with the item (its instrument, the interaction
// model it is about, its text and anchors) and its answer buttons, pressed by poking them with a
// fingertip or by pointing at them and pinching: a button per point of a rating (each with its
// anchor when every one of up to 6 points has one, else the anchors on a line of the panel; rows of
// 11 for a longer scale, and steps of a twentieth of its span for one of more than 21 points, as a
// 0-100 visual analogue scale), a wide one per choice.
import * as THREE from "three";

const JOINTS = [
  "wrist", "thumb-metacarpal", "thumb-phalanx-proximal", "thumb-phalanx-distal", "thumb-tip",
  ...["index", "middle", "ring", "pinky"].flatMap((finger) =>
    ["metacarpal", "phalanx-proximal", "phalanx-intermediate", "phalanx-distal", "tip"].map((j) => `${finger}-finger-${j}`)),
];
const WRIST = 0;
const INDEX_TIP = 9;
const FINGERS = [5, 10, 15, 20];
const SESSION_INIT = { requiredFeatures: ["hand-tracking"], optionalFeatures: ["local-floor"] };
const UP = new THREE.Vector3(0, 1, 0);
const BOARD = { width: 0.5, height: 0.25, clear: 0.05, behind: 0.25 };
const PANEL = { width: 0.62, height: 0.36, above: 0.25, ahead: 0.05, tilt: -0.45 };
const BUTTON = { size: 0.042, gap: 0.008, depth: 0.012, row: -0.09, wide: 0.24, worded: 0.078, perRow: 11, most: 21,
                 mostWorded: 6 };
const TEXT = "#f4f4f4", DIM = "#c9ccd2", GOLD = "#ffd700", RED = "#ff8080";
const PX_PER_M = 2048;
const RAY_LENGTH = 1.0;

/** Offer the headset mode if this browser has WebXR (see the module comment). */
export function setupHeadset(microg) {
  if (!navigator.xr) return;
  const headset = new Headset(microg);
  microg.xr = headset.state;
  headset.offer();
}

/** A flat text panel: a canvas drawn only when its text changes, on a plane `width` x `height` m. */
class Panel {
  constructor(width, height) {
    this.canvas = document.createElement("canvas");
    this.canvas.width = Math.round(width * PX_PER_M);
    this.canvas.height = Math.round(height * PX_PER_M);
    this.texture = new THREE.CanvasTexture(this.canvas);
    this.texture.colorSpace = THREE.SRGBColorSpace;
    this.texture.generateMipmaps = false;  // redrawn with every timer tick: no mipmap chain to rebuild
    this.texture.minFilter = THREE.LinearFilter;
    this.mesh = new THREE.Mesh(new THREE.PlaneGeometry(width, height),
                               new THREE.MeshBasicMaterial({ map: this.texture, transparent: true }));
    this.key = null;
  }

  /** Draw `blocks` ({text, size (px), colour, bold, at: px from the top, else below the last})
   *  wrapped and centred. */
  show(blocks) {
    const key = JSON.stringify(blocks);
    if (key === this.key) return;
    this.key = key;
    const g = this.canvas.getContext("2d");
    const { width, height } = this.canvas;
    g.clearRect(0, 0, width, height);
    g.fillStyle = "rgba(12, 14, 18, 0.82)";
    g.beginPath();
    g.roundRect(0, 0, width, height, 48);
    g.fill();
    g.textAlign = "center";
    g.textBaseline = "top";
    let y = 40;
    for (const { text, size, colour, bold, at } of blocks) {
      if (at !== undefined) y = at;
      g.font = `${bold ? "600 " : ""}${size}px system-ui, sans-serif`;
      g.fillStyle = colour || TEXT;
      for (const line of wrap(g, text, width - 96)) {
        g.fillText(line, width / 2, y);
        y += size * 1.25;
      }
      y += size * 0.35;
    }
    this.texture.needsUpdate = true;
  }
}

function wrap(g, text, width) {
  const lines = [];
  for (const paragraph of String(text).split("\n")) {
    let line = "";
    for (const word of paragraph.split(/\s+/).filter(Boolean)) {
      const next = line ? `${line} ${word}` : word;
      if (line && g.measureText(next).width > width) {
        lines.push(line);
        line = word;
      } else {
        line = next;
      }
    }
    lines.push(line);
  }
  return lines;
}

/** A button `width` x BUTTON.size m with `text` on its face (and `words` under it, smaller). */
function label(text, width = BUTTON.size, words = "") {
  const canvas = document.createElement("canvas");
  canvas.height = 128;
  canvas.width = Math.round(128 * width / BUTTON.size);
  const g = canvas.getContext("2d");
  g.fillStyle = "#2a2f38";
  g.fillRect(0, 0, canvas.width, 128);
  g.fillStyle = TEXT;
  g.textAlign = "center";
  g.textBaseline = "middle";
  g.font = `600 ${words ? 52 : 64}px system-ui, sans-serif`;
  g.fillText(text, canvas.width / 2, words ? 48 : 68, canvas.width - 8);
  if (words) {
    g.font = "600 30px system-ui, sans-serif";
    g.fillText(words, canvas.width / 2, 100, canvas.width - 10);
  }
  const texture = new THREE.CanvasTexture(canvas);
  texture.colorSpace = THREE.SRGBColorSpace;
  const face = new THREE.MeshBasicMaterial({ map: texture });
  const side = new THREE.MeshBasicMaterial({ color: 0x8a8f99 });
  const mesh = new THREE.Mesh(new THREE.BoxGeometry(width, BUTTON.size, BUTTON.depth), [side, side, side, side, face, side]);
  mesh.userData.half = [width / 2, BUTTON.size / 2];
  return mesh;
}

/** What a question's buttons answer: a choice's choices, or a rating's points (for more than
 *  BUTTON.most points, every k-th, so that there are at most that many), with their words. */
function answersOf(question) {
  if (question.response === "choice") {
    return question.choices.map(([value, text], k) => ({ value, text: `${k + 1}: ${text}`, wide: true }));
  }
  const words = new Map(question.anchors.map(([point, text]) => [point, text]));
  const every = question.points.length <= BUTTON.mostWorded && question.points.every((point) => words.has(point));
  const step = Math.ceil((question.points.length - 1) / (BUTTON.most - 1));
  const last = question.points.length - 1;
  return question.points.filter((_, k) => k % step === 0 || k === last)
    .map((point) => ({ value: point, text: String(point), words: every ? words.get(point) : "" }));
}

/** The anchors as one line of the panel, when the buttons do not carry them. */
function anchorLine(question) {
  if (question.response === "choice" || answersOf(question).some((a) => a.words)) return "";
  return question.anchors.map(([point, text]) => `${point}: ${text}`).join("   \u00b7   ");
}

function text(id) {
  return document.getElementById(id).textContent;
}

function shown(id) {
  return !document.getElementById(id).hidden;
}

/** A hand as read this frame: joint positions in the XR reference space, radii, track number. */
function readHand(frame, source, space, poses, radii) {
  const spaces = JOINTS.map((name) => source.hand.get(name));
  if (!frame.fillPoses(spaces, space, poses) || !frame.fillJointRadii(spaces, radii)) return null;
  const points = JOINTS.map((_, k) => new THREE.Vector3(poses[16 * k + 12], poses[16 * k + 13], poses[16 * k + 14]));
  return { side: source.handedness, points, radii: Array.from(radii) };
}

/** The anchor a hand proposes: its palm marks `mark`, its fingers point along the tracker's -z. */
function proposedAnchor(hand, mark) {
  const { points } = hand;
  const palm = new THREE.Vector3();
  const knuckles = new THREE.Vector3();
  for (const base of FINGERS) {
    palm.add(points[base]).add(points[base + 1]);
    knuckles.add(points[base + 1]);
  }
  palm.multiplyScalar(1 / (2 * FINGERS.length));
  knuckles.multiplyScalar(1 / FINGERS.length);
  const forward = knuckles.sub(points[WRIST]);
  forward.y = 0;
  if (forward.lengthSq() < 1e-8) return null;
  const z = forward.normalize().negate();
  const x = new THREE.Vector3().crossVectors(UP, z);
  const rotation = new THREE.Matrix4().makeBasis(x, UP, z);
  return new THREE.Matrix4().makeTranslation(palm).multiply(rotation)
    .multiply(new THREE.Matrix4().makeTranslation(-mark[0], -mark[1], -mark[2]));
}

class Headset {
  constructor(microg) {
    this.microg = microg;
    this.session = null;
    this.space = null;
    this.tracks = new WeakMap();
    this.nextTrack = 1;
    this.hands = new Map();
    this.poses = new Float32Array(16 * JOINTS.length);
    this.radii = new Float32Array(JOINTS.length);
    this.inverse = new THREE.Matrix4();
    this.pokedBy = new Map();
    this.rays = new Map();
    this.raycaster = new THREE.Raycaster();
    /** What tests and the researcher can read: mode, step, anchor, hands sent, answers pressed, the
     *  buttons of the question shown (value and words) and where each is. */
    this.state = { mode: null, step: "off", space: null, anchor: null, sent: 0, pressed: [],
                   button: (value) => this.buttonAt(value),
                   answers: () => this.buttons.map((b) => [b.userData.value, b.userData.words]) };
    this.build();
  }

  async offer() {
    for (const mode of ["immersive-ar", "immersive-vr"]) {
      if (await navigator.xr.isSessionSupported(mode).catch(() => false)) {
        this.state.mode = mode;
        break;
      }
    }
    if (!this.state.mode) return;
    const button = document.createElement("button");
    button.id = "enter-xr";
    button.type = "button";
    button.textContent = "Enter mixed reality";
    button.title = this.state.mode === "immersive-ar" ? "Headset with passthrough" : "Headset (no passthrough available)";
    button.addEventListener("click", () => this.enter().catch((error) => {
      button.textContent = `Enter mixed reality (failed: ${error.message})`;
    }));
    document.getElementById("xr-controls").append(button);
    this.button = button;
  }

  build() {
    this.board = new Panel(BOARD.width, BOARD.height);
    this.panel = new Panel(PANEL.width, PANEL.height);
    this.panelGroup = new THREE.Group();
    this.panelGroup.add(this.panel.mesh);
    this.buttons = [];
    this.preview = new THREE.Group();
    this.preview.matrixAutoUpdate = false;
    this.footprint = new THREE.Mesh(new THREE.PlaneGeometry(1, 1),
                                    new THREE.MeshBasicMaterial({ color: 0x467de8, transparent: true, opacity: 0.35,
                                                                  side: THREE.DoubleSide }));
    this.footprint.rotation.x = -Math.PI / 2;
    this.preview.add(this.footprint);
    const material = new THREE.LineBasicMaterial({ color: 0xffd700 });
    for (const side of ["left", "right"]) {
      const geometry = new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3(0, 0, -RAY_LENGTH)]);
      const line = new THREE.Line(geometry, material);
      line.matrixAutoUpdate = false;
      line.visible = false;
      this.rays.set(side, line);
    }
  }

  async enter() {
    // The headset draws the best level at the resolution its runtime recommends (the layer's
    // framebuffer scale stays 1: three.js fixes it when the session starts, and its runtime, not
    // the page, paces and reprojects the frames); the screen's adapting resumes on leaving.
    const session = await navigator.xr.requestSession(this.state.mode, SESSION_INIT);
    const { quality } = this.microg;
    this.heldOnScreen = quality.held;
    quality.fix(quality.levels[0]);
    const { renderer } = this.microg;
    let type = "local-floor";
    try {
      await session.requestReferenceSpace(type);
    } catch {
      type = "local";
    }
    renderer.xr.enabled = true;
    renderer.xr.setReferenceSpaceType(type);
    await renderer.xr.setSession(session);
    this.session = session;
    this.space = renderer.xr.getReferenceSpace();
    Object.assign(this.state, { step: "placing", space: type, anchor: null });
    session.addEventListener("selectstart", (event) => this.place(event.inputSource));
    session.addEventListener("select", (event) => this.pointAndPinch(event));
    session.addEventListener("end", () => this.leave());
    const scene = this.microg.three;
    this.microg.workspace.root.visible = false;
    scene.add(this.board.mesh, this.preview, ...this.rays.values());
    this.board.mesh.visible = false;
    document.body.classList.add("immersive");
    this.hook = (time, frame) => this.frame(frame);
    this.microg.beforeDraw.push(this.hook);
    this.button.hidden = true;
  }

  leave() {
    const { microg } = this;
    microg.beforeDraw.splice(microg.beforeDraw.indexOf(this.hook), 1);
    microg.three.remove(this.board.mesh, this.preview, ...this.rays.values());
    microg.workspace.root.remove(this.board.mesh, this.panelGroup);
    const root = microg.workspace.root;
    root.matrix.identity();
    root.matrixAutoUpdate = true;
    root.visible = true;
    microg.renderer.xr.enabled = false;
    document.body.classList.remove("immersive");
    microg.dirty = true;
    this.session = null;
    this.hands.clear();
    Object.assign(this.state, { step: "off", anchor: null });
    this.button.hidden = false;
    if (this.heldOnScreen) microg.quality.fix(this.heldOnScreen);
    else microg.quality.release();
  }

  /** Every XR frame: read the hands, then placing, streaming, pressing, and the 3D text. */
  frame(frame) {
    if (!frame || !this.session) return;
    const read = performance.timeOrigin + performance.now();
    this.hands.clear();
    for (const source of this.session.inputSources) {
      if (!source.hand) continue;
      const hand = readHand(frame, source, this.space, this.poses, this.radii);
      if (!hand) continue;
      if (!this.tracks.has(source)) this.tracks.set(source, this.nextTrack++);
      hand.track = this.tracks.get(source);
      this.hands.set(source, hand);
    }
    if (this.state.step === "placing") {
      this.showPlacement(frame);
    } else {
      this.stream(read);
      this.poke();
      this.pointers(frame);
      this.showText();
    }
  }

  showPlacement(frame) {
    const layout = this.microg.layout;
    if (!this.board.mesh.visible) {
      // The instructions stand in front of the participant's head as it is when the session starts.
      const viewer = frame.getViewerPose(this.space);
      if (!viewer) return;
      const head = new THREE.Matrix4().fromArray(viewer.transform.matrix);
      const eye = new THREE.Vector3().setFromMatrixPosition(head);
      const ahead = new THREE.Vector3(0, 0, -1).transformDirection(head);
      ahead.y = 0;
      ahead.normalize();
      this.board.mesh.position.copy(eye).addScaledVector(ahead, 0.7).add(new THREE.Vector3(0, -0.15, 0));
      this.board.mesh.lookAt(eye);
      this.board.mesh.visible = true;
    }
    this.board.show([
      { text: "Place the workspace", size: 64, bold: true },
      { text: "Hold one hand flat, palm down, where the table should be, fingers pointing away from you. " +
              "Then pinch your thumb and index finger together.", size: 42, colour: DIM },
    ]);
    const hand = this.hands.values().next().value;
    const anchor = hand && layout ? proposedAnchor(hand, layout.mark) : null;
    this.preview.visible = Boolean(anchor);
    if (anchor) {
      const [x, y, z] = layout.mark;
      this.footprint.scale.set(layout.footprint[0], layout.footprint[1], 1);
      this.footprint.position.set(x, y, z);
      this.preview.matrix.copy(anchor);
    }
  }

  /** The pinch that ends the placement: the pinching hand's palm anchors the workspace. */
  place(source) {
    const hand = this.hands.get(source);
    const layout = this.microg.layout;
    if (this.state.step !== "placing" || !hand || !layout) return;
    const anchor = proposedAnchor(hand, layout.mark);
    if (!anchor) return;
    const root = this.microg.workspace.root;
    root.matrixAutoUpdate = false;
    root.matrix.copy(anchor);
    root.matrixWorldNeedsUpdate = true;
    root.visible = true;
    this.inverse.copy(anchor).invert();
    this.preview.visible = false;
    const [x, y, z] = layout.mark;
    this.board.mesh.position.set(x, layout.top + BOARD.clear + BOARD.height / 2, z - BOARD.behind);
    this.board.mesh.rotation.set(0, 0, 0);
    this.panelGroup.position.set(x, y + PANEL.above, z + PANEL.ahead);
    this.panelGroup.rotation.set(PANEL.tilt, 0, 0);
    this.panelGroup.visible = false;
    root.add(this.board.mesh, this.panelGroup);
    const rowMajor = anchor.clone().transpose().toArray();
    Object.assign(this.state, { step: "placed", anchor: rowMajor });
    this.microg.send({ type: "placement", anchor: rowMajor, mode: this.state.mode, space: this.state.space,
                       hand: hand.side });
  }

  /** The tracked hands in the workspace frame, to the session (when it reads its hands from the page). */
  stream(read) {
    if (!this.microg.layout || !this.microg.layout.stream_hands) return;
    const hands = [];
    const p = new THREE.Vector3();
    for (const hand of this.hands.values()) {
      const joints = hand.points.map((point) => {
        p.copy(point).applyMatrix4(this.inverse);
        return [round(p.x), round(p.y), round(p.z)];
      });
      hands.push({ side: hand.side, track: hand.track, joints, radii: hand.radii.map(round) });
    }
    this.microg.send({ type: "hands", t: read, hands });
    this.state.sent += 1;
  }

  /** The questionnaire's buttons for the question shown (rebuilt when what they answer changes), in
   *  rows of BUTTON.perRow around BUTTON.row; the note goes under the lowest row. */
  buttonsFor(question) {
    const answers = answersOf(question);
    const key = JSON.stringify(answers);
    if (this.buttonsKey === key) return;
    this.buttonsKey = key;
    for (const button of this.buttons) this.panelGroup.remove(button);
    const width = answers[0].wide ? BUTTON.wide : answers[0].words ? BUTTON.worded : BUTTON.size;
    const perRow = answers[0].wide ? 2 : BUTTON.perRow;
    const rows = Math.ceil(answers.length / perRow);
    const pitch = { x: width + BUTTON.gap, y: BUTTON.size + BUTTON.gap };
    this.buttons = [];
    answers.forEach(({ value, text, words }, k) => {
      const row = Math.floor(k / perRow), inRow = Math.min(perRow, answers.length - row * perRow);
      const button = label(text, width, words);
      button.position.set((k % perRow - (inRow - 1) / 2) * pitch.x, BUTTON.row + ((rows - 1) / 2 - row) * pitch.y,
                          BUTTON.depth / 2 + 0.002);
      Object.assign(button.userData, { value, words });
      this.panelGroup.add(button);
      this.buttons.push(button);
    });
    const lowest = BUTTON.row - (rows - 1) / 2 * pitch.y;
    this.noteAt = Math.round((PANEL.height / 2 - lowest + BUTTON.size) * PX_PER_M);
  }

  /** The centre of the front face of the button for `value` and the way it faces, in the XR
   *  reference space (for tests and for checking a setup by hand). */
  buttonAt(value) {
    const button = this.buttons.find((b) => b.userData.value === value);
    if (!button || !this.panelGroup.visible) return null;
    button.updateWorldMatrix(true, false);
    return { centre: new THREE.Vector3(0, 0, BUTTON.depth / 2).applyMatrix4(button.matrixWorld).toArray(),
             normal: new THREE.Vector3(0, 0, 1).transformDirection(button.matrixWorld).toArray() };
  }

  press(value) {
    this.state.pressed.push(value);
    this.microg.answer(String(value));
  }

  /** A fingertip that comes from the front and reaches a button's face presses it; it must
   *  go back in front of the buttons before it presses again (a hand moving about behind the
   *  panel presses nothing). */
  poke() {
    if (!this.panelGroup.visible) return;
    const local = new THREE.Vector3();
    const face = BUTTON.depth + 0.002;
    for (const hand of this.hands.values()) {
      local.copy(hand.points[INDEX_TIP]);
      this.panelGroup.worldToLocal(local);
      const front = face + hand.radii[INDEX_TIP];
      const before = this.pokedBy.get(hand.side);
      if (local.z > front) {
        this.pokedBy.set(hand.side, "ready");
        continue;
      }
      this.pokedBy.set(hand.side, "in");
      if (before !== "ready" || local.z < face - BUTTON.depth) continue;
      const button = this.buttons.find((b) => Math.abs(local.x - b.position.x) <= b.userData.half[0]
                                              && Math.abs(local.y - b.position.y) <= b.userData.half[1]);
      if (button) this.press(button.userData.value);
    }
  }

  /** While a question is shown, each hand's pointing ray; a pinch presses the button it points at. */
  pointers(frame) {
    for (const line of this.rays.values()) line.visible = false;
    if (!this.panelGroup.visible) return;
    const targets = new Set();
    for (const source of this.session.inputSources) {
      const pose = frame.getPose(source.targetRaySpace, this.space);
      const line = this.rays.get(source.handedness);
      if (!pose || !line) continue;
      line.matrix.fromArray(pose.transform.matrix);
      line.matrixWorldNeedsUpdate = true;
      line.visible = true;
      targets.add(this.aimed(pose));
    }
    for (const button of this.buttons) button.scale.setScalar(targets.has(button) ? 1.15 : 1);
  }

  aimed(pose) {
    const m = new THREE.Matrix4().fromArray(pose.transform.matrix);
    const origin = new THREE.Vector3().setFromMatrixPosition(m);
    const direction = new THREE.Vector3(0, 0, -1).transformDirection(m);
    this.raycaster.set(origin, direction);
    this.raycaster.far = RAY_LENGTH;
    const hit = this.raycaster.intersectObjects(this.buttons, false)[0];
    return hit ? hit.object : null;
  }

  pointAndPinch(event) {
    if (!this.panelGroup.visible || !this.space) return;
    const pose = event.frame.getPose(event.inputSource.targetRaySpace, this.space);
    const target = pose && this.aimed(pose);
    if (target) this.press(target.userData.value);
  }

  /** The page's text (instructions, "get ready", the task's timers, the question) in 3D. */
  showText() {
    const question = this.microg.question;
    const asking = shown("question") && question;
    this.panelGroup.visible = Boolean(asking);
    if (asking) {
      this.buttonsFor(question);
      const note = document.getElementById("question-note");
      const rejected = note.classList.contains("rejected");
      const words = anchorLine(question);
      this.panel.show([
        { text: text("question-label"), size: 36, colour: GOLD, bold: true },
        ...(question.instructions ? [{ text: question.instructions, size: 30, colour: DIM }] : []),
        { text: text("question-text"), size: 48, bold: true },
        ...(words ? [{ text: words, size: 32, colour: DIM }] : []),
        { text: rejected ? note.textContent : "Touch an answer, or point at it and pinch.", size: 34,
          colour: rejected ? RED : DIM, at: this.noteAt },
      ]);
    }
    if (shown("hud")) {
      this.board.show([
        { text: text("hud-task"), size: 48, colour: GOLD, bold: true },
        { text: text("hud-stage"), size: 54, bold: true },
        { text: text("hud-place"), size: 48 },
        { text: text("hud-attempts"), size: 40, colour: DIM },
      ]);
    } else if (shown("message")) {
      this.board.show([
        { text: text("message-title"), size: 64, bold: true },
        { text: text("message-text"), size: 40, colour: DIM },
      ]);
    }
    this.board.mesh.visible = !asking;
  }
}

function round(value) {
  return Math.round(value * 1e5) / 1e5;
}
