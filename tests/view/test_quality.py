"""How the participant's page chooses what it draws (``page/quality.js``), run in Node on simulated
frames: half a second of animation frames with nothing to draw, then a frame drawn every animation
frame, its draw time following a cost model of the level; a frame that takes longer than the
refresh interval misses refreshes, and the GPU timer's result arrives a frame later. Time is
simulated: nothing here depends on how fast this machine is."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

from microg.view.display import PAGE

NODE = shutil.which("node")
pytestmark = pytest.mark.skipif(NODE is None, reason="needs Node.js (the page's setup installs it: npm)")

HARNESS = """
import * as quality from %(module)s;
const spec = %(spec)s;
const IDLE_S = 0.5;
const levels = quality.ladder(spec.antialias);
const q = new quality.Quality(levels);
q.timed = spec.timed;
if (spec.fix) q.fix(spec.fix);
// The draw time (ms) of a frame at `level` at time t: the phase of the cost model that holds then,
// base + perPixel * scale^2 (times antialias where it is on), or `above` over `cliff` scale.
function cost(level, t) {
  const phase = spec.phases.filter((p) => t >= p.from * 1000).pop();
  if (phase.cliff !== undefined) return level.scale > phase.cliff ? phase.above : phase.below;
  return (phase.base + phase.perPixel * level.scale ** 2) * (level.antialias ? phase.antialias : 1);
}
// Before the session's first frame the page has nothing new to draw: its animation frames come at
// the display's refresh rate.
let t = 0, pending = null;
for (; t < IDLE_S * 1000; t += spec.refresh) q.frame(t, false);
const trace = [];
let frames = 0;
while (t < spec.seconds * 1000) {
  if (pending !== null && spec.timed) q.gpuTime(pending);
  pending = null;
  if (spec.release && t >= spec.release * 1000 && q.held) q.release();
  if (frames++ %% spec.every) {  // no new frame from the session: nothing drawn
    q.frame(t, false);
    t += spec.refresh;
    continue;
  }
  const ms = cost(q.level, t);
  trace.push([t, q.level.scale, q.level.antialias, ms]);
  pending = ms;
  q.frame(t, true);
  t += Math.max(1, Math.ceil(ms / spec.refresh)) * spec.refresh;  // a frame that takes longer misses refreshes
}
console.log(JSON.stringify({ levels, trace, constants: { FIT: quality.FIT, HOLD_MS: quality.HOLD_MS,
  PROBE_MS: quality.PROBE_MS, BACKOFF_MS: quality.BACKOFF_MS, BACKOFF_MAX_MS: quality.BACKOFF_MAX_MS } }));
"""


def simulate(phases, seconds=60.0, refresh=1000 / 60, timed=True, antialias=False, fix=None, release=None,
             every=1):
    """The frames a page draws under the cost model ``phases`` (see HARNESS), a new one from the
    session every ``every`` animation frames: ``levels`` (the ladder), ``trace`` (time s, scale,
    antialiasing, draw time ms per drawn frame) and the constants."""
    spec = dict(phases=phases, seconds=seconds, refresh=refresh, timed=timed, antialias=antialias, fix=fix,
                release=release, every=every)
    script = HARNESS % {"module": json.dumps((PAGE / "quality.js").as_uri()), "spec": json.dumps(spec)}
    done = subprocess.run([NODE, "--input-type=module"], input=script, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    trace = np.array([(t / 1e3, scale, antialias, ms) for t, scale, antialias, ms in result["trace"]])
    return result["levels"], trace, result["constants"]


def changes(trace):
    """(time s, scale before, scale after) of each change of level."""
    moved = np.flatnonzero(np.diff(trace[:, 1]) != 0) + 1
    return [(trace[k, 0], trace[k - 1, 1], trace[k, 1]) for k in moved]


def test_the_ladder_lowers_the_resolution_first_then_antialiasing_and_a_software_renderer_never_multisamples():
    levels, _, _ = simulate([{"from": 0, "base": 1, "perPixel": 0}], seconds=0.1, antialias=True)
    software, _, _ = simulate([{"from": 0, "base": 1, "perPixel": 0}], seconds=0.1, antialias=False)
    assert levels[0] == {"scale": 1, "antialias": True} and software[0] == {"scale": 1, "antialias": False}
    scales = [level["scale"] for level in levels]
    assert scales == sorted(scales, reverse=True)
    first_plain = next(k for k, level in enumerate(levels) if not level["antialias"])
    assert all(level["antialias"] for level in levels[:first_plain])
    assert not any(level["antialias"] for level in levels[first_plain:])
    assert levels[first_plain]["scale"] == levels[first_plain - 1]["scale"], "antialiasing goes at the lowest scale"
    assert not any(level["antialias"] for level in software)
    assert [level["scale"] for level in software] == sorted({level["scale"] for level in levels}, reverse=True)


@pytest.mark.parametrize("hz", [60, 120])
def test_a_frame_that_does_not_fit_the_refresh_steps_down_to_the_level_that_fits(hz):
    refresh = 1000 / hz
    # draw time proportional to the pixels: 1.2 refresh intervals at full resolution, so within
    # FIT (0.6) of the interval at scale <= 0.707: 0.7 is the level that fits
    _, trace, constants = simulate([{"from": 0, "base": 0, "perPixel": 1.2 * refresh}], refresh=refresh)
    assert trace[0, 1] == 1
    settled = trace[trace[:, 0] > 2.0]
    assert set(settled[:, 1]) == {0.7}
    assert settled[:, 3].max() <= constants["FIT"] * refresh
    assert len(changes(trace)) == 1, "straight to the level that fits, and it stays there"


def test_frames_coming_at_half_the_refresh_rate_are_measured_all_the_same():
    # a 30 Hz tracker on a 60 Hz display: no two animation frames in a row draw
    _, trace, constants = simulate([{"from": 0, "base": 0, "perPixel": 20.0}], every=2)
    assert set(trace[trace[:, 0] > 3, 1]) == {0.7}


def test_with_headroom_again_the_page_climbs_back_to_full_resolution_one_level_at_a_time():
    # a busy computer for 10 s (full resolution takes 2.3 refresh intervals), then an idle one (0.2)
    _, trace, constants = simulate([{"from": 0, "base": 0, "perPixel": 38.0}, {"from": 10, "base": 0, "perPixel": 3.3}])
    at_ten = trace[np.searchsorted(trace[:, 0], 9.9), 1]
    assert at_ten == 0.5
    assert trace[-1, 1] == 1
    climb = [c for c in changes(trace) if c[0] > 10]
    assert [after for _, _, after in climb] == [0.6, 0.7, 0.85, 1]
    assert np.all(np.diff([t for t, _, _ in climb]) >= constants["HOLD_MS"] / 1e3)


def test_a_raise_that_does_not_hold_is_tried_less_and_less_often():
    # the draw time jumps past the budget above scale 0.6, which the pixel count does not predict:
    # every raise to 0.7 fails, and the page tries it again after a back-off that doubles
    _, trace, constants = simulate([{"from": 0, "cliff": 0.6, "below": 4.0, "above": 14.0}], seconds=600)
    raises = [t for t, before, after in changes(trace) if before < after == 0.7]
    gaps = np.diff(raises)
    assert len(raises) >= 5
    assert gaps[0] >= constants["BACKOFF_MS"] / 1e3
    assert np.all(gaps[1:] >= np.minimum(1.8 * gaps[:-1], constants["BACKOFF_MAX_MS"] / 1e3))
    budget = constants["FIT"] * 1000 / 60
    over = trace[trace[:, 0] > 5, 3] > budget
    assert over.mean() < 0.01, "over the budget less than 1 % of the frames once settled"


def test_bursts_of_other_work_do_not_make_the_page_wary_of_a_level():
    # every 7 s from 10 s on, 1.5 s of another program's burst makes every level too slow (40 ms):
    # the page drops, and then climbs straight back (a level each half second) to 0.7 before the
    # next burst, without backing off the level the burst caught it at
    phases = [{"from": 0, "base": 0, "perPixel": 6.0}]
    bursts = [10.0 + 7 * k for k in range(8)]
    for start in bursts:
        phases += [{"from": start, "base": 40, "perPixel": 0}, {"from": start + 1.5, "base": 0, "perPixel": 6.0}]
    _, trace, _ = simulate(phases, seconds=bursts[-1] + 7)
    for start in bursts:
        between = trace[(trace[:, 0] > start + 1.5) & (trace[:, 0] < start + 7), 1]
        assert between.min() <= 0.4 and between.max() >= 0.7, start


def test_without_a_gpu_timer_missed_refreshes_step_down_and_the_page_probes_up_now_and_then():
    # 1.8 refresh intervals at full resolution: frames take two refreshes down to scale 0.7 (0.88)
    _, trace, constants = simulate([{"from": 0, "base": 0, "perPixel": 30.0}], seconds=300, timed=False)
    settled = trace[trace[:, 0] > 10]
    assert np.mean(settled[:, 1] == 0.7) > 0.95
    probes = [t for t, before, after in changes(trace) if after > before]
    assert probes and probes[0] >= constants["PROBE_MS"] / 1e3
    assert np.all(np.diff(probes) >= constants["PROBE_MS"] / 1e3)


def test_a_level_held_stays_whatever_it_costs_until_released():
    held = {"scale": 1, "antialias": False}
    _, trace, _ = simulate([{"from": 0, "base": 0, "perPixel": 38.0}], seconds=20, fix=held, release=10)
    before, after = trace[trace[:, 0] < 10], trace[trace[:, 0] > 15]
    assert set(before[:, 1]) == {1} and np.all(before[:, 3] == 38)
    assert set(after[:, 1]) == {0.5}
