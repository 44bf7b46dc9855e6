// How much the page draws, chosen so that a frame fits the display's refresh interval.
//
// The page measures how long each frame's drawing takes: the GPU's own time for the frame's draw
// calls where the browser has a timer for it (EXT_disjoint_timer_query_webgl2: the result comes a
// frame or two later, once the GPU has finished), and everywhere the interval between two
// animation frames that both drew. Every WINDOW measured frames (GPU times where there is a timer,
// else intervals) it decides:
// - down, when the median draw time is over FIT of the refresh interval, or the median interval
//   between drawn frames over MISSED refresh intervals (frames missed, whatever the cause): to the
//   first level whose draw time, scaled by its pixels, fits; at least one level, at most DROP;
// - up one level, when the frames kept up, the level has been held HOLD_MS, and the level above,
//   predicted from the median draw time (scaled by its pixels, and by ANTIALIAS where it turns
//   antialiasing on), fits within RAISE of the budget. Without a GPU timer there is no
//   headroom to see: the page tries the level above once it has held this one PROBE_MS.
// Medians, because on a shared computer a frame now and then waits for a core.
// A level left within PROBATION_MS of being raised to, when the level below then fits again, was
// too much: it is not tried again for a back-off that doubles each time (BACKOFF_MS up to
// BACKOFF_MAX_MS), so the page settles instead of swinging. When the level below does not fit
// either, the computer got busier (another program's burst): that is no reason to back off.
// This module knows nothing of three.js: participant.js applies the level chosen.

/** The levels, best first: the render resolution comes down first, then antialiasing goes, then
 *  the resolution comes down further. `scale` multiplies the screen's device pixel ratio. Without
 *  a usable GPU there is no antialiasing: multisampling in a software rasteriser costs several
 *  times a frame's drawing (twice to three times, measured here in SwiftShader). Lighting costs
 *  next to nothing at every level (workspace.js), so it stays. */
export function ladder(antialias) {
  const scales = [1, 0.85, 0.7, 0.6, 0.5];
  return [
    ...scales.map((scale) => ({ scale, antialias })),
    ...[...(antialias ? [0.5] : []), 0.4, 0.33, 0.25].map((scale) => ({ scale, antialias: false })),
  ];
}

export const WINDOW = 12;
export const FIT = 0.6;
export const MISSED = 1.5;
export const RAISE = 0.75;
export const DROP = 3;
/** What turning multisampling on multiplies a frame's draw time by: 2 to 3 times in software
 *  (SwiftShader, 1280 x 800), an upper guess for a GPU; a raise that does not hold is backed off. */
export const ANTIALIAS = 2.5;
/** Frames after a change that are not measured (new buffers, new shaders). */
export const SETTLE = 2;
export const HOLD_MS = 500;
export const PROBE_MS = 4000;
export const PROBATION_MS = 3000;
export const BACKOFF_MS = 4000;
export const BACKOFF_MAX_MS = 120000;
/** The shortest refresh interval believed (a 250 Hz display). */
export const SHORTEST_REFRESH_MS = 4;

function quantile(values, q) {
  const sorted = Array.from(values).sort((a, b) => a - b);
  return sorted[Math.min(sorted.length - 1, Math.floor(q * sorted.length))];
}

/** Chooses the level (see the module comment); `onChange(level)` applies a new one. */
export class Quality {
  constructor(levels, onChange = () => {}) {
    this.levels = levels;
    this.index = 0;
    /** A level held whatever the draw time (`fix`), or null while adapting. */
    this.held = null;
    this.onChange = onChange;
    /** Whether draw times come from a GPU timer (the page says so once it knows). */
    this.timed = false;
    /** The display's refresh interval (ms): the shortest interval between animation frames seen. */
    this.refresh = Infinity;
    /** The last draw time measured (ms of GPU time; NaN without a timer). */
    this.cost = NaN;
    this.costs = new Float64Array(WINDOW);
    this.intervals = new Float64Array(WINDOW);
    this.blockedUntil = new Float64Array(levels.length);
    this.backoff = new Float64Array(levels.length).fill(BACKOFF_MS);
    this.raisedTo = -1;
    this.raisedAt = 0;
    /** A level left soon after raising to it, judged at the next decision (see the module comment). */
    this.suspect = -1;
    this.changedAt = 0;
    this.restart();
  }

  /** The level drawn now. */
  get level() {
    return this.held || this.levels[this.index];
  }

  /** Hold `level` ({scale, antialias}; a test's still picture, a benchmark's fixed run). */
  fix(level) {
    this.held = level;
    this.restart();
    this.onChange(this.level);
  }

  /** Adapt again, from the level held before `fix`. */
  release() {
    this.held = null;
    this.restart();
    this.onChange(this.level);
  }

  /** Forget the window's measurements (a change, or a pause in drawing that says nothing of its
   *  cost: a headset session, a hidden page). */
  restart() {
    this.measured = 0;
    this.spaced = 0;
    this.settling = SETTLE;
    this.lastTime = null;
    this.lastDrew = false;
  }

  /** A drawn frame's GPU time (ms), when its timer result arrives. */
  gpuTime(ms) {
    this.cost = ms;
    if (this.settling > 0) return;
    this.costs[this.measured % WINDOW] = ms;
    this.measured += 1;
  }

  /** Once every animation frame, after drawing: its timestamp (ms) and whether it drew. */
  frame(time, drew) {
    if (this.lastTime !== null) {
      const interval = time - this.lastTime;
      if (interval >= SHORTEST_REFRESH_MS) this.refresh = Math.min(this.refresh, interval);
      if (drew && this.lastDrew && this.settling === 0) {
        this.intervals[this.spaced % WINDOW] = interval;
        this.spaced += 1;
      }
    }
    if (drew && this.settling > 0) this.settling -= 1;
    this.lastTime = time;
    this.lastDrew = drew;
    if (!this.held && (this.timed ? this.measured : this.spaced) >= WINDOW) this.decide(time);
  }

  decide(now) {
    const budget = FIT * this.refresh;
    const cost = this.timed ? quantile(this.costs, 0.5) : NaN;
    const missed = this.spaced >= WINDOW && quantile(this.intervals, 0.5) > MISSED * this.refresh;
    const over = missed || cost > budget;
    const last = this.levels.length - 1;
    if (this.suspect >= 0 && !over) {
      this.blockedUntil[this.suspect] = now + this.backoff[this.suspect];
      this.backoff[this.suspect] = Math.min(2 * this.backoff[this.suspect], BACKOFF_MAX_MS);
    }
    this.suspect = -1;
    let target = this.index;
    if (over && this.index < last) {
      target += 1;
      while (this.timed && target < Math.min(last, this.index + DROP) &&
             cost * this.pixels(target) / this.pixels(this.index) > budget) target += 1;
      if (this.raisedTo === this.index && now - this.raisedAt < PROBATION_MS) this.suspect = this.index;
    } else if (!over && this.index > 0 && now >= this.blockedUntil[this.index - 1]) {
      const above = this.levels[this.index - 1], here = this.levels[this.index];
      if (this.timed) {
        const predicted = cost * this.pixels(this.index - 1) / this.pixels(this.index) *
                          (above.antialias && !here.antialias ? ANTIALIAS : 1);
        if (predicted <= RAISE * budget && now - this.changedAt >= HOLD_MS) target -= 1;
      } else if (now - this.changedAt >= PROBE_MS) {
        target -= 1;
      }
    }
    if (this.raisedTo === this.index && now - this.raisedAt >= PROBATION_MS) {
      this.backoff[this.index] = BACKOFF_MS;  // the raise held: the next failure starts afresh
      this.raisedTo = -1;
    }
    this.measured = 0;
    this.spaced = 0;
    if (target === this.index) return;
    if (target < this.index) {
      this.raisedTo = target;
      this.raisedAt = now;
    }
    this.index = target;
    this.changedAt = now;
    this.restart();
    this.onChange(this.level);
  }

  /** Pixels drawn at ladder level `index`, relative to the full resolution. */
  pixels(index) {
    return this.levels[index].scale ** 2;
  }
}

/** The GPU's time for the draw calls between `begin` and `end` (EXT_disjoint_timer_query_webgl2),
 *  read back once the GPU has finished them; `available` is false where the browser has no such
 *  timer. Queries are reused: nothing is allocated per frame. */
export class GpuTimer {
  constructor(gl) {
    this.gl = gl;
    this.ext = gl.getExtension("EXT_disjoint_timer_query_webgl2");
    this.pending = [];
    this.spare = [];
  }

  get available() {
    return this.ext !== null;
  }

  begin() {
    if (!this.ext) return;
    const query = this.spare.pop() || this.gl.createQuery();
    this.gl.beginQuery(this.ext.TIME_ELAPSED_EXT, query);
    this.pending.push(query);
  }

  end() {
    if (this.ext) this.gl.endQuery(this.ext.TIME_ELAPSED_EXT);
  }

  /** Hand each finished frame's time (ms), oldest first, to `take`; a timing the GPU disturbed
   *  (a power-state change, another context's work: GPU_DISJOINT_EXT) is dropped. */
  poll(take) {
    const { gl, ext } = this;
    if (!ext || !this.pending.length) return;
    const disjoint = gl.getParameter(ext.GPU_DISJOINT_EXT);
    while (this.pending.length && gl.getQueryParameter(this.pending[0], gl.QUERY_RESULT_AVAILABLE)) {
      const query = this.pending.shift();
      if (!disjoint) take(gl.getQueryParameter(query, gl.QUERY_RESULT) / 1e6);
      this.spare.push(query);
    }
  }
}
