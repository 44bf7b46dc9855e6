"""The whole study at a glance, read from its store while sessions write it: what the dashboard shows.

``study_overview(store)`` is the overview as plain data (dicts, lists, numbers, strings: JSON as it
is). ``Overview(store)`` keeps what it read and reads on from there: each ``refresh`` asks SQLite
whether another connection committed anything (``PRAGMA data_version``) and, only then, reads the
rows added since the last read, by rowid (events, frames, answers, tasks, runs, sessions,
participants), in one read transaction; the few rows that can still change (running task runs and
sessions, active participants, stations) are read again. Reading a store in WAL mode through a
read-only connection never blocks a session's writes, and each read reads a batch's place and times,
never its frames (``frames.data``).

What it holds (``Overview.summary``):

- ``enrolment``: per group of the protocol, its target size, the participants active and withdrawn,
  and the active ones by the balance variable (gender);
- ``participants``, each with the ids of their sessions (``sessions``: a participant may have
  several), the station holding them (``microg.study.stations``), withdrawn or not;
- ``sessions``: status, input, station; each task's state by its last run; for a running one the
  phase, the task (index of how many), its object, stage, place and attempts so far, frames and
  seconds logged; data quality: the tracking guard's counts (summed over its finished runs), frames
  logged per second of the frames' own times against the tracker's rate, the page's display
  settings and clock where the session logged them, timeouts, skips, interrupted runs, resumes;
  questionnaire answers received of those its timeline asks;
- ``results``: every measured task (completion time of a completed one, attempts of one that
  completed, timed out or was aborted: the trials table's rules, ``microg.study.export``) of the
  participants not withdrawn, and the means per phase, group and object, which equal the trials
  table's;
- ``questionnaires``: answers received per instrument, administration and interaction model;
- ``stations``: made, merged, taken back; ``integrity``: the last check's record beside the study
  (``microg.study.integrity``: when, which check, sound or the problems a writer found) and what the
  check when this overview opened the study found; ``export``: the newest export in the study folder
  (``export.json``), how many facts were committed since it, and the newest report beside it.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections import Counter, defaultdict
from datetime import date, datetime, timezone
from pathlib import Path

from microg.schema import REPORT_FILE

from . import integrity, ledger
from .export import MANIFEST
from .questionnaire import questions
from .schedule import Sitting, session_states
from .stations import given_up, stations
from .store import FINAL_RUN, Store, archived, DATABASE

MEASURED_TIME = ("completed",)
"""Last-run statuses whose completion time counts (the trials table's ``time_s``)."""
MEASURED_ATTEMPTS = ("completed", "timeout", "aborted")
"""Last-run statuses whose attempts count (the trials table's ``attempts``)."""
READ_EVENTS = ("phase_start", "phase_end", "stage", "drop", "place_done", "tracking_guard", "display_quality",
               "display_clock", "display_latency", "session_resume", "questionnaire_skipped")
"""The events whose data the overview reads."""
FILES_EVERY_S = 5.0
"""How often (s) ``refresh`` looks for a newer export and report in the study folder."""
GUARD = {"dropped": ("duplicate_timestamps", "out_of_order"), "incomplete": ("hands_incomplete",),
         "gaps": ("gaps",), "re_anchored": ("clock_resyncs",), "jumps": ("jumps",),
         "jumps_accepted": ("jumps_accepted",), "jumps_rejected": ("jumps_rejected",), "lost": ("jumps_lost",)}
"""The tracking guard's counts as the overview groups them (``microg.hands.GuardCounts``)."""


def study_overview(store: Store) -> dict:
    """The overview of ``store`` as plain data (module docstring)."""
    overview = Overview(store)
    overview.refresh()
    return overview.summary()


def _utc(seconds: float) -> str:
    return datetime.fromtimestamp(seconds, timezone.utc).isoformat(timespec="seconds")


class Overview:
    """An overview that reads on from where it was (module docstring)."""

    def __init__(self, store: Store):
        self.store, self.db, self.protocol = store, store.db, store.protocol
        self._version: int | None = None
        self._marks = dict.fromkeys(("participant", "session", "task", "run", "frame", "event", "answer"), 0)
        self.participants: dict[str, dict] = {}
        self.sessions: dict[int, dict] = {}
        self.tasks: dict[int, dict[int, dict]] = defaultdict(dict)
        """Session id -> task index -> the planned task."""
        self.runs: dict[int, dict] = {}
        self.session_runs: dict[int, list[dict]] = defaultdict(list)
        self.last_run: dict[tuple[int, int], int] = {}
        """(session, task index) -> its last run's id (the highest run number)."""
        self.answers: dict[int, Counter] = defaultdict(Counter)
        """Session id -> (instrument, administration, interaction) -> answers."""
        self.stations: list[dict] = []
        self.ledger_head = 0
        self._files_at: float | None = None
        self._record_stamp = None
        self.record: integrity.Record | None = None
        self.export: dict | None = None
        self.report: Path | None = None
        """The newest ``report.html`` in the study folder or its last export (what the dashboard serves)."""

    # ------------------------------------------------------------ reading

    def refresh(self) -> bool:
        """Read what was committed since the last call, and look again at the check's record and (every
        ``FILES_EVERY_S``) the newest export; whether anything the summary holds changed."""
        changed = self._read_record()
        now = time.monotonic()
        if self._files_at is None or now - self._files_at >= FILES_EVERY_S:
            self._files_at = now
            changed |= self._read_files()
        version = self.db.execute("PRAGMA data_version").fetchone()[0]
        if version == self._version:
            return changed
        self.db.execute("BEGIN")  # one snapshot: a session committing meanwhile does not tear the picture
        try:
            self._read_participants()
            self._read_sessions()
            self._read_tasks()
            self._read_runs()
            self._read_frames()
            self._read_events()
            self._read_answers()
            self._read_stations()
            self.ledger_head = self.db.execute("SELECT COALESCE(MAX(seq), 0) FROM ledger").fetchone()[0]
        finally:
            self.db.execute("COMMIT")
        self._version = version  # only once all was read: a read that failed is tried again
        return True

    def _newer(self, mark: str, query: str) -> list:
        """Rows of ``query`` (its first column the rowid, selected ``> ?``) after the mark, which moves on."""
        rows = self.db.execute(query, (self._marks[mark],)).fetchall()
        if rows:
            self._marks[mark] = max(self._marks[mark], max(row[0] for row in rows))
        return rows

    def _read_participants(self) -> None:
        active = [pid for pid, p in self.participants.items() if p["status"] == "active"]
        for row in self._newer("participant", "SELECT number, id, group_code, gender, status FROM participants "
                                              "WHERE number > ? ORDER BY number"):
            self.participants[row["id"]] = {"id": row["id"], "number": row["number"], "group": row["group_code"],
                                            "gender": row["gender"], "status": row["status"], "station": None,
                                            "sessions": []}
        if active:
            marks = ",".join("?" * len(active))
            for row in self.db.execute(f"SELECT id, status FROM participants WHERE id IN ({marks}) "
                                       "AND status != 'active'", active):
                self.participants[row["id"]]["status"] = row["status"]

    def _read_sessions(self) -> None:
        running = [sid for sid, s in self.sessions.items() if s["status"] == "running"]
        marks = ",".join("?" * len(running))
        rows = self.db.execute("SELECT id, participant_id, name, date, status, input, simulated, station, merged_at, "
                               "created_at, ended_at FROM sessions WHERE id > ?" + (f" OR id IN ({marks})" if running else ""),
                               (self._marks["session"], *running)).fetchall()
        for row in rows:
            self._marks["session"] = max(self._marks["session"], row["id"])
            session = self.sessions.get(row["id"])
            if session is None:
                session = self.sessions[row["id"]] = _new_session(row)
                self.participants[row["participant_id"]]["sessions"].append(row["id"])
            session.update(status=row["status"], ended_at=row["ended_at"])

    def _read_tasks(self) -> None:
        for row in self._newer("task", "SELECT rowid, session_id, task_index, phase, interaction, object, object_code, "
                                       "order_position FROM tasks WHERE rowid > ?"):
            self.tasks[row["session_id"]][row["task_index"]] = {
                "phase": row["phase"], "interaction": row["interaction"], "object": row["object_code"],
                "object_name": row["object"], "order_position": row["order_position"]}

    def _read_runs(self) -> None:
        running = [rid for rid, r in self.runs.items() if r["status"] == "running"]
        marks = ",".join("?" * len(running))
        rows = self.db.execute("SELECT id, session_id, task_index, run, status, time_s, attempts, started_at, ended_at "
                               "FROM task_runs WHERE id > ?" + (f" OR id IN ({marks})" if running else ""),
                               (self._marks["run"], *running)).fetchall()
        for row in rows:
            self._marks["run"] = max(self._marks["run"], row["id"])
            run = self.runs.get(row["id"])
            if run is None:
                run = self.runs[row["id"]] = {"session": row["session_id"], "task": row["task_index"],
                                              "run": row["run"], "frames": 0, "t_first": None, "t_last": None,
                                              "stage": None, "place": None, "places_done": 0, "attempts_so_far": 0}
                self.session_runs[row["session_id"]].append(run)
                key = (row["session_id"], row["task_index"])
                if key not in self.last_run or self.runs[self.last_run[key]]["run"] < row["run"]:
                    self.last_run[key] = row["id"]
            run.update(status=row["status"], time_s=row["time_s"], attempts=row["attempts"])

    def _read_frames(self) -> None:
        for row in self._newer("frame", "SELECT rowid, run_id, count, t_first, t_last FROM frames WHERE rowid > ?"):
            run = self.runs[row["run_id"]]
            run["frames"] += row["count"]
            run["t_first"] = row["t_first"] if run["t_first"] is None else min(run["t_first"], row["t_first"])
            run["t_last"] = row["t_last"] if run["t_last"] is None else max(run["t_last"], row["t_last"])

    def _read_events(self) -> None:
        kinds = ",".join(f"'{kind}'" for kind in READ_EVENTS)
        rows = self._newer("event", f"SELECT id, session_id, run_id, kind, CASE WHEN kind IN ({kinds}) THEN data END "
                                    "AS data FROM events WHERE id > ? ORDER BY id")
        for row in rows:
            if row["data"] is None:
                continue
            data, session, kind = json.loads(row["data"]), self.sessions[row["session_id"]], row["kind"]
            run = self.runs.get(row["run_id"])
            if kind == "phase_start":
                session["phase"] = data["phase"]
            elif kind == "phase_end" and session["phase"] == data["phase"]:
                session["phase"] = None
            elif kind == "stage" and run is not None:
                run["stage"], run["place"] = data.get("stage"), data.get("place")
            elif kind == "drop" and run is not None:
                run["attempts_so_far"] = data.get("attempts", run["attempts_so_far"] + 1)
            elif kind == "place_done" and run is not None:
                run["places_done"] += 1
            elif kind == "tracking_guard":
                guard = session["guard"]
                for name, count in data.items():
                    guard[name] = guard.get(name, 0) + count
            elif kind in ("display_quality", "display_clock", "display_latency"):
                session["display"][kind.removeprefix("display_")] = data
            elif kind == "session_resume":
                session["resumes"] += 1
            elif kind == "questionnaire_skipped":
                session["questionnaire_skipped"] = True

    def _read_answers(self) -> None:
        for row in self._newer("answer", "SELECT rowid, session_id, instrument, administration, interaction "
                                         "FROM answers WHERE rowid > ?"):
            self.answers[row["session_id"]][(row["instrument"], row["administration"], row["interaction"])] += 1

    def _read_stations(self) -> None:
        self.stations = []
        for made in stations(self.db):
            merged = self.db.execute("SELECT COUNT(*) FROM sessions WHERE station = ? AND merged_at IS NOT NULL",
                                     (made.name,)).fetchone()[0]
            self.stations.append({"name": made.name, "made_at": made.made_at, "participants": list(made.participants),
                                  "merged": merged, "given_up": sorted(given_up(self.db, made.name))})
        for participant in self.participants.values():
            holding = self.store.station_holding(participant["id"]) if self.stations else None
            participant["station"] = None if holding is None else holding[0]

    def _read_record(self) -> bool:
        """The check's record beside the study, read again when its file changed."""
        try:
            stat = os.stat(self.store.dir / integrity.RECORD)
            stamp = (stat.st_mtime_ns, stat.st_size, stat.st_ino)
        except OSError:
            stamp = None
        if stamp == self._record_stamp:
            return False
        self._record_stamp, self.record = stamp, integrity.read(self.store.dir)
        return True

    def _read_files(self) -> bool:
        """The newest export in the study folder (a subfolder with ``export.json``) and the newest report
        in the study folder or the export's subfolders; whether either changed."""
        folder = self.store.dir
        manifests = [path for path in folder.glob(f"*/{MANIFEST}") if path.is_file()]
        newest = max(manifests, key=_mtime, default=None)
        export = None
        if newest is not None:
            try:
                manifest = json.loads(newest.read_text())
            except (OSError, ValueError):
                manifest = {}
            head = manifest.get("ledger_head")
            export = {"folder": str(newest.parent.relative_to(folder)), "written_at": _utc(_mtime(newest)),
                      "files": len(manifest.get("files", [])), "damaged": list(manifest.get("damaged", [])),
                      "ledger_entry": ledger.parse_head(head).entry if head else None}
        places = [folder, *(() if newest is None else (newest.parent,))]
        reports = [path for place in places for path in place.glob(f"*/{REPORT_FILE}") if path.is_file()]
        report = max(reports, key=_mtime, default=None)
        changed = export != self.export or report != self.report
        self.export, self.report = export, report
        return changed

    # ------------------------------------------------------------ the summary

    def summary(self) -> dict:
        """What was read, as plain data (module docstring)."""
        return {"study": self._study(), "integrity": self._integrity(), "enrolment": self._enrolment(),
                "participants": [self._participant(p) for p in self.participants.values()],
                "sessions": [self._session(s) for s in self.sessions.values()], "results": self._results(),
                "questionnaires": self._questionnaires(), "stations": self.stations, "export": self._export()}

    def _study(self) -> dict:
        protocol = self.protocol
        return {"name": self.store.name, "folder": str(self.store.dir), "protocol": protocol.name,
                "station": self.store.station, "archived": archived(self.store.dir / DATABASE),
                "tracking_rate": protocol.tracking_rate, "balance": protocol.balance,
                "groups": [g.code for g in protocol.groups], "objects": [o.code for o in protocol.objects],
                "object_names": {o.code: o.name for o in protocol.objects}, "program": protocol.program}

    def _integrity(self) -> dict:
        record = self.record
        return {"opened": list(self.store.problems),
                "record": None if record is None else {"checked_at": record.checked_at, "check": record.check,
                                                       "sound": record.sound, "problems": list(record.problems)}}

    def _enrolment(self) -> dict:
        groups = []
        for group in self.protocol.groups:
            members = [p for p in self.participants.values() if p["group"] == group.code]
            active = [p for p in members if p["status"] == "active"]
            groups.append({"code": group.code, "name": group.name, "size": group.size, "active": len(active),
                           "withdrawn": len(members) - len(active),
                           "by": dict(sorted(Counter(p["gender"] for p in active).items()))})
        return {"target": self.protocol.total_participants, "balance": self.protocol.balance, "groups": groups,
                "active": sum(g["active"] for g in groups), "withdrawn": sum(g["withdrawn"] for g in groups)}

    def _participant(self, participant: dict) -> dict:
        """A participant's row; in a training program with what is next: a session due (on a date, or
        overdue) or later, from the sessions they ran (``microg.study.schedule``)."""
        row = {key: participant[key] for key in ("id", "group", "gender", "status", "station", "sessions")}
        if self.protocol.program and participant["status"] == "active":
            sittings = [Sitting(s["name"], date.fromisoformat(s["date"]), s["status"])
                        for s in (self.sessions[sid] for sid in participant["sessions"])]
            upcoming = [state for state in session_states(self.protocol, participant["group"], sittings, date.today())
                        if state.state in ("due", "overdue")]
            row["next"] = None if not upcoming else {"session": upcoming[0].name, "state": upcoming[0].state,
                                                     "due": upcoming[0].due.isoformat()}
        return row

    def _session(self, session: dict) -> dict:
        sid = session["id"]
        planned = self.tasks.get(sid, {})
        states = {index: self._last(sid, index) for index in planned}
        counts = Counter(run["status"] if run else "not_run" for run in states.values())
        runs = self.session_runs[sid]
        frames = sum(r["frames"] for r in runs)
        intervals = sum(r["frames"] - 1 for r in runs if r["frames"] > 1)
        span = sum(r["t_last"] - r["t_first"] for r in runs if r["frames"] > 1)
        guard = session["guard"]
        participant = self.participants[session["participant"]]
        return {**{key: session[key] for key in ("id", "participant", "name", "date", "status", "input", "simulated",
                                                 "station",
                                                 "merged_at", "created_at", "ended_at", "phase", "resumes")},
                "group": participant["group"], "tasks": len(planned),
                "done": sum(run is not None and run["status"] in FINAL_RUN for run in states.values()),
                "counts": dict(counts), "running": self._running(sid, runs, len(planned)),
                "quality": {"frames": frames, "rate_hz": intervals / span if span > 0 else None,
                            "tracking_rate": self.protocol.tracking_rate,
                            "guard": {name: sum(guard.get(c, 0) for c in parts) for name, parts in GUARD.items()}
                            if guard else None,
                            "timeouts": counts["timeout"], "skipped": counts["skipped"], "aborted": counts["aborted"],
                            "interrupted_runs": sum(r["status"] == "interrupted" for r in runs),
                            "display": session["display"] or None},
                "answers": sum(self.answers[sid].values()), "answers_expected": self._expected(participant["group"]),
                "questionnaire_skipped": session["questionnaire_skipped"]}

    def _last(self, session: int, index: int) -> dict | None:
        run_id = self.last_run.get((session, index))
        return None if run_id is None else self.runs[run_id]

    def _running(self, session: int, runs: list[dict], planned: int) -> dict | None:
        """A running task run of the session: where it is."""
        run = next((r for r in runs if r["status"] == "running"), None)
        if run is None:
            return None
        task = self.tasks[session][run["task"]]
        places = len(self.protocol.rules(task["phase"]).places)
        return {"task": run["task"], "of": planned, "run": run["run"], "phase": task["phase"],
                "interaction": task["interaction"], "object": task["object"], "object_name": task["object_name"],
                "stage": run["stage"], "place": run["place"], "places": places, "places_done": run["places_done"],
                "attempts": run["attempts_so_far"], "frames": run["frames"],
                "elapsed_s": run["t_last"] - run["t_first"] if run["frames"] else 0.0}

    def _expected(self, group: str) -> int:
        """The answers a session of ``group`` asks for (its first session's timeline)."""
        return sum(len(questions(self.protocol, phase)) for phase in self.protocol.phases_for(group)
                   if phase.instruments)

    def _results(self) -> dict:
        """Every measured task of the participants not withdrawn, and the means per phase, group and
        object (the trials table's rules)."""
        points = []
        for (sid, index), run_id in self.last_run.items():
            run, session = self.runs[run_id], self.sessions[sid]
            participant = self.participants[session["participant"]]
            if participant["status"] == "withdrawn" or run["status"] not in MEASURED_ATTEMPTS:
                continue
            task = self.tasks[sid][index]
            points.append({"participant": participant["id"], "session": sid, "group": participant["group"],
                           "phase": task["phase"], "object": task["object"], "task": index, "status": run["status"],
                           "time_s": run["time_s"] if run["status"] in MEASURED_TIME else None,
                           "attempts": run["attempts"]})
        present = {t["phase"] for tasks in self.tasks.values() for t in tasks.values()}
        phases = [name for name in dict.fromkeys(p.name for p in self.protocol.timeline) if name in present]
        cells: dict[tuple, list[dict]] = defaultdict(list)
        for point in points:
            cells[point["phase"], point["group"], point["object"]].append(point)
        ranks = [{name: rank for rank, name in enumerate(names)} for names in (
            phases, [g.code for g in self.protocol.groups], [o.code for o in self.protocol.objects])]
        means = []
        for (phase, group, obj), members in sorted(cells.items(), key=lambda cell: [
                (rank.get(part, len(rank)), part) for rank, part in zip(ranks, cell[0])]):  # the protocol's order
            times = [p["time_s"] for p in members if p["time_s"] is not None]
            attempts = [p["attempts"] for p in members if p["attempts"] is not None]
            means.append({"phase": phase, "group": group, "object": obj, "tasks": len(members),
                          "completed": len(times), "time_s": math.fsum(times) / len(times) if times else None,
                          "attempts": math.fsum(attempts) / len(attempts) if attempts else None})
        return {"phases": phases, "points": points, "means": means}

    def _questionnaires(self) -> list[dict]:
        totals: dict[tuple, list[int]] = defaultdict(lambda: [0, 0])
        for counts in self.answers.values():
            for key, n in counts.items():
                totals[key][0] += n
                totals[key][1] += 1
        return [{"instrument": i, "administration": a, "interaction": x, "answers": n, "sessions": s}
                for (i, a, x), (n, s) in sorted(totals.items())]

    def _export(self) -> dict | None:
        if self.export is None and self.report is None:
            return None
        export = dict(self.export or {})
        if export.get("ledger_entry") is not None:
            export["facts_since"] = self.ledger_head - export["ledger_entry"]
        if self.report is not None:
            export["report"] = {"path": str(self.report.relative_to(self.store.dir)),
                                "written_at": _utc(_mtime(self.report))}
        return export


def _new_session(row) -> dict:
    return {"id": row["id"], "participant": row["participant_id"], "name": row["name"], "date": row["date"],
            "status": row["status"], "input": row["input"],
            "simulated": bool(row["simulated"]), "station": row["station"], "merged_at": row["merged_at"],
            "created_at": row["created_at"], "ended_at": row["ended_at"], "phase": None, "guard": {},
            "display": {}, "resumes": 0, "questionnaire_skipped": False}


def _mtime(path: Path) -> float:
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0

