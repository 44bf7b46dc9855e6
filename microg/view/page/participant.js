// The participant's page: what the session sends, drawn at the display's refresh rate.
//
// Frames arrive over the WebSocket as fast as the physics computes them (a phase's added latency
// later: the session holds them); the page keeps only the newest and draws it on the next
// animation frame, so it never falls behind. It measures how long its drawing takes and chooses
// the render resolution and antialiasing so that a frame fits the display's refresh interval
// (quality.js), raising them again when there is headroom. Timeline messages (instructions, "get
// ready", the completion cue, the questionnaire's items) change the text over the scene. The page syncs its clock to the session's and, with ?latency=1 in its
// address, reports when it drew each frame and at what level; ?quality=full holds the best level
// whatever it costs (a benchmark's reference run). window.microg exposes what was drawn, for tests
// and for the headset module (xr.js), which adds the "Enter mixed reality" button where the
// browser offers WebXR.
import * as THREE from "three";
import { GpuTimer, Quality, SETTLE, WINDOW, ladder } from "./quality.js";
import { Workspace } from "./workspace.js";
import { setupHeadset } from "./xr.js";

const params = new URLSearchParams(location.search);
const OTHER_HAND = { left: "right", right: "left" };

/** A stage's words, as the task's kind says them (the scene's ``stages``), with the hands a kind
 *  names filled in. */
function stageText(stage) {
  const text = (workspace.layout && workspace.layout.stages && workspace.layout.stages[stage]) || stage;
  const first = workspace.layout && workspace.layout.first_hand;
  return first ? text.replace("{first}", first).replace("{other}", OTHER_HAND[first]) : text;
}

/** Whether WebGL runs on a graphics card, not a software rasteriser (SwiftShader, llvmpipe: a
 *  computer without a usable GPU), where the page never multisamples (quality.js). */
function onGraphicsCard() {
  const gl = document.createElement("canvas").getContext("webgl2");
  if (!gl) return false;
  const debug = gl.getExtension("WEBGL_debug_renderer_info");
  const name = String(gl.getParameter(debug ? debug.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
  gl.getExtension("WEBGL_lose_context")?.loseContext();
  return !/swiftshader|llvmpipe|softpipe|software/i.test(name);
}

const scene = new THREE.Scene();
scene.background = new THREE.Color(0x1b1e24);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 10);
camera.position.set(0, 0.45, 0.55);
camera.lookAt(0, 0.2, 0);
const workspace = new Workspace();
scene.add(workspace.root);

const microg = {
  /** The newest frame message received, and the last one drawn. */
  latest: null,
  drawn: null,
  /** Something besides a frame changed the picture (a new scene, a resize). */
  dirty: true,
  /** While true, new frames are received but not drawn (a test holds the picture still). */
  hold: false,
  scene: null,
  /** Answers the session accepted (committed) so far, and every question shown, in order. */
  answered: 0,
  questions: [],
  camera,
  /** The WebGL renderer: a new one on a new canvas whenever antialiasing turns on or off. */
  renderer: null,
  /** What the page draws (quality.js): `level`, `fix(level)`, `release()`. */
  quality: null,
  /** Animation frames so far, and the last picture drawn: its level, its drawing buffer's size
   *  (px) and the animation frame that drew it. */
  animationFrames: 0,
  picture: { level: null, width: 0, height: 0, frame: 0 },
  three: scene,
  workspace,
  /** The session's workspace message: the point a headset's placement marks, the table's footprint. */
  layout: null,
  socket: null,
  clockOffset: 0,
  /** The last clock sync: offset to the session's clock, quickest round trip, spread (ms). */
  clock: null,
  /** Screen pixel (x, y from the top left) of a point in the tracker's frame. */
  project(x, y, z) {
    const p = new THREE.Vector3(x, y, z).project(camera);
    const rect = microg.renderer.domElement.getBoundingClientRect();
    return [rect.left + (p.x + 1) / 2 * rect.width, rect.top + (1 - p.y) / 2 * rect.height];
  },
  /** The session's clock now (ms). */
  now() {
    return performance.timeOrigin + performance.now() + microg.clockOffset;
  },
  send(message) {
    if (microg.socket && microg.socket.readyState === WebSocket.OPEN) microg.socket.send(JSON.stringify(message));
  },
  /** Draw hooks another module (the headset's) adds: called with (frame) after each new frame. */
  onFrame: [],
  onScene: [],
  /** Called with (time, xrFrame) at the start of every animation frame, before anything is drawn. */
  beforeDraw: [],
  /** With ?latency=1: what the page reported drawing, until someone takes them (a benchmark). */
  reports: [],
};
window.microg = microg;

// ---------------------------------------------------------------- text over the scene

const message = document.getElementById("message");
const hud = document.getElementById("hud");
const question = document.getElementById("question");

function say(title, text) {
  document.getElementById("message-title").textContent = title;
  document.getElementById("message-text").textContent = text || "";
  message.hidden = false;
  question.hidden = true;
}

function capital(word) {
  return word.charAt(0).toUpperCase() + word.slice(1);
}

function timeline(m) {
  if (m.kind === "phase") {
    hud.hidden = true;
    say(capital(m.phase), m.text);
  } else if (m.kind === "ready") {
    hud.hidden = true;
    say("Get ready", `${m.label}\nThe task starts when the researcher starts it.`);
  } else if (m.kind === "task") {
    message.hidden = true;
    hud.hidden = false;
    document.getElementById("hud-task").textContent = m.label;
  } else if (m.kind === "done") {
    hud.hidden = true;
    const result = m.status === "completed" ? `Completed in ${m.time_s.toFixed(1)} s` :
                   m.status === "timeout" ? "Time is up for this task" : "This task has ended";
    say(m.status === "completed" ? "Well done" : "Task over", result);
  } else if (m.kind === "progress") {  // training to a criterion: how far, under the last task's cue
    hud.hidden = true;
    const text = document.getElementById("message-text");
    if (message.hidden) say("Training", m.text); else text.textContent = `${text.textContent}\n${m.text}`;
  }
}

/** The task's stage, timers and attempts, set only when what they show changes (the timers by
 *  tenths of a second): the page neither builds their text nor lays it out every frame. */
const shownHud = { stage: null, task: null, place: null, lit: null, timer: null, places: null, held: null,
                   attempts: null };
const hudStage = document.getElementById("hud-stage");
const hudPlace = document.getElementById("hud-place");
const hudAttempts = document.getElementById("hud-attempts");

function showHud(frame) {
  const shown = shownHud;
  const places = workspace.layout ? workspace.layout.places.length : 0;
  const task = Math.round(frame.task_timer * 10), timer = Math.round(frame.place_timer * 10);
  if (frame.stage !== shown.stage || task !== shown.task) {
    hudStage.textContent = `${stageText(frame.stage)} · ${(task / 10).toFixed(1)} s`;
  }
  const place = frame.place !== shown.place || frame.lit !== shown.lit || places !== shown.places ||
    frame.held !== shown.held;
  if (workspace.layout && !places) {
    if (place) hudPlace.textContent = frame.held ? "Holding" : "Not holding";
  } else if (place || (frame.lit && timer !== shown.timer)) {
    hudPlace.textContent = frame.lit
      ? `Place ${frame.place + 1} lit: ${(timer / 10).toFixed(1)} / ${workspace.layout.hold_s} s`
      : frame.place < places ? `Place ${frame.place + 1} of ${places}` : `All ${places} places done`;
  }
  if (frame.attempts !== shown.attempts) hudAttempts.textContent = `Attempts: ${frame.attempts}`;
  shown.stage = frame.stage;
  shown.task = task;
  shown.place = frame.place;
  shown.lit = frame.lit;
  shown.timer = timer;
  shown.places = places;
  shown.held = frame.held;
  shown.attempts = frame.attempts;
}

// ---------------------------------------------------------------- the questionnaire

// One item at a time: the instrument and the interaction model it is about above the item's text; a
// rating of up to MAX_BUTTONS points as a row of buttons (each with its anchor when every point has
// one, else the anchors under the row), a longer one (NASA-TLX's 21 steps, a 0-100 visual analogue
// scale) as a slider and a Confirm button, a choice (NASA-TLX's pairs) as a button per choice. Keys:
// type the number and press Enter (for a choice, its number); on the slider, the arrows and Enter.
// Each answer goes with the question's number and the time since it was shown (ms).
const MAX_BUTTONS = 11;
let typed = "";
let shownAt = 0;

function described(m) {
  return [m.label, m.title, m.count > 1 ? `${m.number} of ${m.count}` : ""].filter(Boolean).join(" · ");
}

function button(value, text, anchor) {
  const element = document.createElement("button");
  element.type = "button";
  element.dataset.value = String(value);
  element.setAttribute("role", "radio");
  element.append(text);
  if (anchor) {
    const words = document.createElement("span");
    words.className = "anchor";
    words.textContent = anchor;
    element.append(words);
    element.classList.add("anchored");
  }
  element.addEventListener("click", () => answer(String(value)));
  return element;
}

/** The anchors under the scale, each at its point's share of the way from one end to the other. */
function showAnchors(m) {
  const row = document.getElementById("anchors");
  row.replaceChildren();
  for (const [point, text] of m.anchors) {
    const share = (point - m.min) / (m.max - m.min);
    const span = document.createElement("span");
    span.textContent = `${point}: ${text}`;
    if (share === 1) {
      span.className = "end";
    } else {
      span.style.left = `${100 * share}%`;
      if (share === 0) span.className = "start";
    }
    row.append(span);
  }
}

function ask(m) {
  message.hidden = true;
  hud.hidden = true;
  question.hidden = false;
  typed = "";
  shownAt = performance.now();
  microg.question = m;
  microg.questions.push(m);
  document.getElementById("question-label").textContent = described(m);
  document.getElementById("question-instructions").textContent = m.instructions || "";
  document.getElementById("question-text").textContent = m.question;
  const note = document.getElementById("question-note");
  note.classList.remove("rejected");
  const scale = document.getElementById("scale");
  const slider = document.getElementById("slider");
  scale.replaceChildren();
  document.getElementById("anchors").replaceChildren();
  slider.hidden = true;
  if (m.response === "choice") {
    m.choices.forEach(([value, text], k) => {
      const element = button(value, `${k + 1}: ${text}`);
      element.classList.add("choice");
      scale.append(element);
    });
    note.textContent = "Click one, or type its number and press Enter.";
  } else if (m.points.length <= MAX_BUTTONS) {
    const words = new Map(m.anchors.map(([point, text]) => [point, text]));
    const every = m.points.every((point) => words.has(point));
    for (const point of m.points) scale.append(button(point, String(point), every ? words.get(point) : ""));
    if (!every) showAnchors(m);
    note.textContent = "Click a number, or type it and press Enter.";
  } else {
    const input = document.getElementById("slider-input");
    Object.assign(input, { min: m.min, max: m.max, step: m.step });
    input.value = m.points[Math.floor(m.points.length / 2)];
    document.getElementById("slider-value").textContent = input.value;
    slider.hidden = false;
    showAnchors(m);
    input.focus();
    note.textContent = "Move the slider (or the arrow keys), then Confirm (or Enter).";
  }
}

function answer(value) {
  if (!microg.question) return;
  microg.send({ type: "answer", seq: microg.question.seq, value, rt: performance.now() - shownAt });
}
microg.answer = answer;

document.getElementById("slider-input").addEventListener("input", (event) => {
  document.getElementById("slider-value").textContent = event.target.value;
});
document.getElementById("slider-confirm").addEventListener("click", () => {
  answer(document.getElementById("slider-input").value);
});

document.addEventListener("keydown", (event) => {
  if (question.hidden) return;
  if (/^[0-9]$/.test(event.key)) {
    typed = (typed + event.key).slice(-3);
  } else if (event.key === "Backspace") {
    typed = typed.slice(0, -1);
  } else if (event.key === "Enter") {
    if (typed) answer(typed);
    else if (!document.getElementById("slider").hidden) answer(document.getElementById("slider-input").value);
    typed = "";
  } else {
    return;
  }
  event.preventDefault();
  for (const element of document.querySelectorAll("#scale button")) {
    element.classList.toggle("chosen", element.dataset.value === typed);
  }
});
question.addEventListener("submit", (event) => event.preventDefault());

// ---------------------------------------------------------------- the connection

// The clock: bursts of 12 pings, one every 10 s. Each ping gives the session's clock minus the
// page's, measured at the middle of its round trip; it is off by at most half the round trip, so
// the offset is the mean of the 4 quickest of the last 48 (four bursts, 40 s, too short for the two
// clocks to drift apart by much): a page busy drawing handles some pongs late, and those are left out.
const samples = [];
const KEPT_SAMPLES = 48;
const BURST = 12;
let burst = 0;

function ping() {
  microg.send({ type: "ping", t0: performance.timeOrigin + performance.now() });
}

function pong(m) {
  const t1 = performance.timeOrigin + performance.now();
  samples.push({ rtt: t1 - m.t0, offset: m.ts - (m.t0 + t1) / 2 });
  if (samples.length > KEPT_SAMPLES) samples.shift();
  burst += 1;
  if (burst < BURST) {
    setTimeout(ping, 20);
    return;
  }
  burst = 0;
  const best = [...samples].sort((a, b) => a.rtt - b.rtt).slice(0, 4);
  const offsets = best.map((p) => p.offset);
  microg.clockOffset = offsets.reduce((a, b) => a + b, 0) / offsets.length;
  microg.clock = { offset: microg.clockOffset, rtt: best[0].rtt, spread: Math.max(...offsets) - Math.min(...offsets) };
  microg.send({ type: "clock", ...microg.clock });
  setTimeout(ping, 10000);
}

function connect() {
  const token = params.get("token");
  const socket = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws` +
                               (token ? `?token=${encodeURIComponent(token)}` : ""));
  microg.socket = socket;
  socket.addEventListener("open", () => {
    say("Connected", "Waiting for the session to begin.");
    ping();
    reportLevel();
  });
  socket.addEventListener("message", (event) => {
    const m = JSON.parse(event.data);
    if (m.type === "frame") {
      m.received = microg.now();
      microg.latest = m;
    } else if (m.type === "workspace") {
      microg.layout = m;
    } else if (m.type === "scene") {
      microg.scene = m;
      workspace.setScene(m);
      const { eye, target, fov_deg } = m.camera;
      camera.fov = fov_deg;
      camera.position.set(...eye);
      camera.lookAt(...target);
      camera.updateProjectionMatrix();
      microg.latest = null;
      microg.dirty = true;
      calibrating = CALIBRATION_FRAMES;
      for (const hook of microg.onScene) hook(m);
    } else if (m.type === "timeline") {
      timeline(m);
    } else if (m.type === "question") {
      ask(m);
    } else if (m.type === "rejected") {
      const note = document.getElementById("question-note");
      note.textContent = m.message;
      note.classList.add("rejected");
    } else if (m.type === "accepted") {
      microg.answered += 1;
      say("Thank you", "Your answer is saved.");
    } else if (m.type === "pong") {
      pong(m);
    }
  });
  socket.addEventListener("close", () => {
    say("Disconnected", "The session's page server has stopped.");
  });
}

// ---------------------------------------------------------------- drawing

let timer = null;
/** A new task's scene is drawn this many animation frames in a row, before the task's first frame
 *  if the session waits ("get ready"): three decisions' worth of measurements, so the task starts
 *  at a level that fits. */
const CALIBRATION_FRAMES = 3 * (WINDOW + SETTLE);
let calibrating = 0;

/** Draw on a new canvas with a new renderer: antialiasing is fixed when a WebGL context is made. */
function useRenderer(antialias) {
  const old = microg.renderer;
  const canvas = document.createElement("canvas");
  canvas.id = "scene";
  const renderer = new THREE.WebGLRenderer({ canvas, antialias });
  if (old) {
    old.setAnimationLoop(null);
    old.dispose();
    old.forceContextLoss();
  }
  document.getElementById("scene").replaceWith(canvas);
  microg.renderer = renderer;
  timer = new GpuTimer(renderer.getContext());
  microg.quality.timed = timer.available;
  renderer.setAnimationLoop(draw);
}

function resize() {
  if (microg.renderer.xr.isPresenting) return;  // the headset's layer sets the size (three.js)
  const width = window.innerWidth, height = window.innerHeight;
  microg.renderer.setPixelRatio(window.devicePixelRatio * microg.quality.level.scale);
  microg.renderer.setSize(width, height, false);
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
  microg.dirty = true;
}

/** Tell the session the level drawn (it logs it: display_quality). */
function reportLevel() {
  const { scale, antialias } = microg.quality.level;
  const { width, height } = microg.renderer.domElement;
  microg.send({ type: "quality", scale, antialias, width, height, refresh: microg.quality.refresh,
                cost: microg.quality.cost });
}

/** Draw at `level` from now on. */
function useLevel(level) {
  const { renderer } = microg;
  if (!renderer || renderer.getContextAttributes().antialias !== level.antialias) useRenderer(level.antialias);
  resize();
  reportLevel();
}

const measure = params.get("latency") === "1";
const KEPT_REPORTS = 100000;
const quality = new Quality(ladder(onGraphicsCard()), useLevel);
microg.quality = quality;
const gpuTime = (ms) => quality.gpuTime(ms);

function draw(time, xrFrame) {
  microg.animationFrames += 1;
  const { renderer } = microg;
  const presenting = renderer.xr.isPresenting;
  if (!presenting) timer.poll(gpuTime);
  for (const hook of microg.beforeDraw) hook(time, xrFrame);
  const frame = microg.hold ? microg.drawn : microg.latest;
  const fresh = frame && frame !== microg.drawn;
  if (fresh) {
    workspace.setFrame(frame);
    showHud(frame);
    for (const hook of microg.onFrame) hook(frame);
  }
  const start = microg.now();
  const drew = Boolean(fresh || microg.dirty || presenting || calibrating > 0);
  if (drew) {
    if (calibrating > 0) calibrating -= 1;
    if (!presenting) timer.begin();
    renderer.render(scene, camera);
    if (!presenting) timer.end();
    microg.dirty = false;
    const { picture } = microg;
    picture.level = quality.level;
    picture.width = renderer.domElement.width;
    picture.height = renderer.domElement.height;
    picture.frame = microg.animationFrames;
  }
  if (fresh) {
    microg.drawn = frame;
    if (measure) {
      const drawn = microg.now();
      const { scale, antialias } = quality.level;
      const report = { type: "drawn", i: frame.i, t: frame.t, ready: frame.ready, due: frame.due,
                       received: frame.received, render: drawn - start, drawn, scale, antialias,
                       width: renderer.domElement.width, height: renderer.domElement.height,
                       gpu: presenting ? null : quality.cost };
      // Hands read in this page: from reading them to drawing their physics, on the page's own clock.
      if (frame.read != null) report.trip = performance.timeOrigin + performance.now() - frame.read;
      microg.send(report);
      microg.reports.push(report);
      if (microg.reports.length > KEPT_REPORTS) microg.reports.splice(0, microg.reports.length - KEPT_REPORTS);
    }
  }
  if (!presenting) quality.frame(time, drew);
}
microg.draw = draw;
window.addEventListener("resize", resize);
if (params.get("quality") === "full") quality.fix(quality.levels[0]);
else useLevel(quality.level);
connect();
setupHeadset(microg);
