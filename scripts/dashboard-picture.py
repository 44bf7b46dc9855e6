"""The README's picture of the dashboard (docs/img/dashboard.png), taken as a test takes one: a study of the
paper's protocol whose sessions simulated participants ran (one withdrawn, one still running, paced at real
time), exported, shown by ``microg dashboard`` in headless Chromium.

    PYTHONPATH=. python scripts/dashboard-picture.py [OUT.png]

It takes a few minutes (the first simulated session compiles the physics).
"""

from __future__ import annotations

import sys
import tempfile
import threading
from pathlib import Path

from microg.paths import protocol_file
from microg.study.assignment import paper_sample
from microg.study.export import export_study
from microg.study.inputs import PacedInputs, open_inputs
from microg.study.protocol import load_protocol
from microg.study.session import make_clock, run_session
from microg.study.simulated_rater import SimulatedRater
from microg.study.store import create_study, open_study
from microg.view.dashboard import Dashboard

from tests.view.browser import chromium
from tests.waiting import wait_until

SEED = 11
ENDED = 10
"""Participants whose sessions have ended when the picture is taken; the next one's runs."""
WIDTH = 1280


def run(folder: Path, pid: str, paced: bool = False) -> None:
    with open_study(folder) as store:
        inputs = open_inputs("simulated", store.protocol.group(store.participant(pid).group))
        inputs = PacedInputs(inputs, 1.0) if paced else inputs
        session = store.create_session(pid, input_spec=inputs.spec, simulated=True, clock=inputs.clock)
        run_session(store, session.id, inputs, clock=make_clock(inputs.clock),
                    rater=SimulatedRater(store, session.id, session.seed))


def main(out: Path) -> None:
    folder = Path(tempfile.mkdtemp()) / "s1"
    with create_study(folder, load_protocol(protocol_file("paper")), SEED) as store:
        for person in paper_sample(SEED)[:ENDED + 2]:
            store.add_participant(person)
        people = [p.id for p in store.participants()]
    for pid in people[:ENDED]:
        run(folder, pid)
        print(f"ran {pid}", flush=True)
    with open_study(folder) as store:
        store.withdraw(people[1], "moved away")
    export_study(folder, folder / "export", frames=False, bids=False, progress=False)
    running = threading.Thread(target=run, args=(folder, people[ENDED], True), daemon=True)
    running.start()
    with open_study(folder, readonly=True) as store, Dashboard(store) as board, chromium((WIDTH, 900)) as driver:
        driver.get(board.url)
        wait_until(lambda: driver.execute_script(
            "const r = document.querySelector('tr[data-status=running] .frames'); return r && +r.textContent > 600"),
            "a running session with frames on the page")
        height = driver.execute_script("return document.documentElement.scrollHeight")
        driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",  # the whole page in the viewport
                               {"width": WIDTH, "height": height, "deviceScaleFactor": 1, "mobile": False})
        drawn = driver.execute_script("return window.microg.updates")
        wait_until(lambda: driver.execute_script("return window.microg.updates") > drawn + 1,
                   "the page to draw twice more at its new size")
        out.write_bytes(driver.get_screenshot_as_png())
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/img/dashboard.png"))
