"""The questionnaires of the VR protocol on the participant's page, in headless Chromium: SSQ before
and after, IPQ and NASA-TLX (its ratings on a slider, its pairwise comparisons as choices) after each
interaction model, the paper's items and SUS, each item answered on the page and committed as it is
given; a session killed (SIGKILL) in the middle of a questionnaire and resumed asks only the items
not answered yet; the answers and their scores land in the store and the export."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from microg.study.assignment import Participant
from microg.study.export import export_study
from microg.study.protocol import load_protocol
from microg.study.questionnaire import questions
from microg.study.store import create_study, open_study
from tests.study.conftest import PROTOCOLS

from .browser import MISSING, chromium
from .conftest import free_port

needs_browser = pytest.mark.skipif(bool(MISSING), reason=f"needs {MISSING} (apt-get install chromium "
                                                         "chromium-driver; pip install selenium)")
ROOT = Path(__file__).resolve().parents[2]
WINDOW = (1000, 700)
WORK_S = 300.0
"""A generous bound for a session and a browser on a loaded machine: every wait ends on an event; this
only keeps a broken run from hanging."""
KILL_AT = 40
"""Answers committed before the kill: the SSQ before (16), the IPQ after stage 1 (14), 10 of its NASA-TLX."""

ANSWER = """
// Answer `count` more items as a participant would: a rating's button (each item its own point), the
// slider of a long rating and its Confirm button, a choice's button; each after its question is shown,
// the next once the session has committed it. Resolves with what was pressed.
const [count, done] = [arguments[0], arguments[arguments.length - 1]];
const microg = window.microg, form = document.getElementById("question");
const until = (ok) => new Promise((resolve) => { const poll = () => ok() ? resolve() : setTimeout(poll, 5); poll(); });
(async () => {
  const pressed = [];
  for (let k = 0; k < count; k++) {
    const answered = microg.answered;
    await until(() => !form.hidden && microg.question && microg.question.seq > (microg.lastPressed || 0));
    const m = microg.question;
    let value;
    if (m.response === "choice") {
      value = m.choices[m.seq % 2][0];
      document.querySelector(`#scale button[data-value="${value}"]`).click();
    } else if (m.points.length <= 11) {
      value = m.points[m.seq % m.points.length];
      document.querySelector(`#scale button[data-value="${value}"]`).click();
    } else {
      value = m.points[(3 * m.seq) % m.points.length];
      const input = document.getElementById("slider-input");
      input.value = value;
      input.dispatchEvent(new Event("input"));
      document.getElementById("slider-confirm").click();
    }
    microg.lastPressed = m.seq;
    pressed.push([m.instrument, m.administration, m.interaction, m.item, String(value)]);
    await until(() => microg.answered > answered);
  }
  done(pressed);
})();
"""


def start(folder: Path, mode: str) -> tuple[subprocess.Popen, str]:
    """The session's process (``questionnaire_child``) and the page's address once it serves it."""
    child = subprocess.Popen([sys.executable, "-m", "tests.view.questionnaire_child", str(folder), mode,
                              str(free_port())], cwd=ROOT, stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONUNBUFFERED": "1"})
    line = child.stdout.readline()
    assert line.startswith("url "), f"the session printed {line!r} instead of its page's address"
    return child, line.split()[1]


def wait(driver, script: str):
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(driver, WORK_S, poll_frequency=0.05).until(lambda d: d.execute_script(script))


def committed(folder: Path) -> list[tuple]:
    """The answers as another process sees the database: their keys and values, in the order given."""
    with sqlite3.connect(f"file:{folder / 'study.db'}?mode=ro", uri=True) as db:
        return db.execute("SELECT instrument, administration, interaction, item, CAST(value AS TEXT) FROM answers "
                          "ORDER BY rowid").fetchall()


@needs_browser
@pytest.mark.slow
def test_the_vr_questionnaires_are_answered_on_the_page_and_a_killed_session_asks_only_what_is_left(tmp_path):
    from selenium.webdriver.common.by import By

    protocol = load_protocol(PROTOCOLS / "tiny-vr.toml")
    folder = tmp_path / "study"
    with create_study(folder, protocol, seed=1) as store:
        group = store.add_participant(Participant("P01", "female", 24, "right", True)).group
    expected = [q.key for phase in protocol.phases_for(group) if phase.instruments for q in questions(protocol, phase)]
    child, url = start(folder, "run")
    try:
        with chromium(WINDOW) as driver:
            driver.set_script_timeout(WORK_S)
            driver.get(url)
            # The first item: an answer off the scale typed on the keyboard is refused and logged.
            wait(driver, "return window.microg.question && !document.getElementById('question').hidden")
            assert "Simulator Sickness Questionnaire (SSQ) · 1 of 16" in driver.find_element(By.ID, "question-label").text
            assert [b.text for b in driver.find_elements(By.CSS_SELECTOR, "#scale button")] == [
                "0\nNone", "1\nSlight", "2\nModerate", "3\nSevere"]
            driver.find_element(By.TAG_NAME, "body").send_keys("7\n")
            wait(driver, "return document.getElementById('question-note').classList.contains('rejected')")
            assert "7 is off the scale: type a whole number from 0 to 3" in driver.find_element(By.ID, "question-note").text
            before = driver.execute_async_script(ANSWER, KILL_AT)
            # The next item is shown once the last answer is committed: kill the session there.
            wait(driver, f"return window.microg.questions.length === {KILL_AT + 1}")
            child.send_signal(signal.SIGKILL)
            child.wait(WORK_S)
            assert [tuple(row[:4]) for row in committed(folder)] == expected[:KILL_AT]

            child, url = start(folder, "resume")
            driver.get(url)
            after = driver.execute_async_script(ANSWER, len(expected) - KILL_AT)
            shown = driver.execute_script("return window.microg.questions.map((m) => [m.instrument, m.administration, "
                                          "m.interaction, m.item])")
            assert child.wait(WORK_S) == 0
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()

    assert [tuple(q) for q in shown] == expected[KILL_AT:]  # the resumed session asked only what was left
    assert committed(folder) == [tuple(p) for p in before + after]
    with open_study(folder) as store:
        session = store.session_of("P01")
        assert store.session(session.id).status == "completed"
        rejected = [e.data for e in store.events(session.id) if e.kind == "answer_rejected"]
        assert [(r["instrument"], r["item"], r["answer"]) for r in rejected] == [("ssq", "ssq01", "7")]
        times = [r[0] for r in store.db.execute("SELECT response_time_s FROM answers")]
        assert len(times) == len(expected) and all(0 < t < WORK_S for t in times)
    out = tmp_path / "export"
    export_study(folder, out, frames=False, bids=False, progress=False, say=lambda text: None)
    answers = pd.read_csv(out / "answers.csv", dtype=str, keep_default_na=False)
    assert len(answers) == len(expected) and (answers["source"] == "participant").all()
    scores = pd.read_csv(out / "scores.csv", keep_default_na=False, na_values=[""])
    assert scores["score"].notna().all()
    assert set(scores["instrument"]) == {"ssq", "ipq", "tlx", "paper", "sus"}
    assert {"weighted", "raw"} <= set(scores.loc[scores.instrument == "tlx", "scale"])
