// The researcher's dashboard: draws the study's overview (microg.study.overview) each time the server
// pushes a new one over the WebSocket, and asks it for the view of a session. Everything shown comes from
// the overview; text from the study is escaped before it goes into the page.
"use strict";

const token = new URLSearchParams(location.search).get("token") || "";
const microg = (window.microg = { overview: null, updates: 0, views: {}, charts: {}, error: null });
const COLOURS = ["#1d5fbf", "#c2410c", "#15803d", "#7e22ce", "#0e7490", "#a16207"];
const LOW_RATE = 0.9;  // a session logging fewer frames a second than this share of the tracker's rate is marked
const GUARD_SHOWN = [["dropped", "dropped"], ["gaps", "gaps"], ["re_anchored", "re-anchored"], ["jumps", "jumps"],
                     ["incomplete", "incomplete hands"]];
let socket = null;

function esc(value) {
  return String(value ?? "").replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;",
                                                          "'": "&#39;" })[c]);
}

function fixed(value, digits = 2) {
  return value == null ? "–" : Number(value).toFixed(digits);
}

function when(iso) {
  return iso ? new Date(iso).toLocaleString() : "";
}

function connect() {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  socket = new WebSocket(`${scheme}://${location.host}/ws?token=${encodeURIComponent(token)}`);
  socket.onopen = () => live("on", "live");
  socket.onmessage = (event) => receive(JSON.parse(event.data));
  socket.onclose = () => {
    live("off", "not connected: trying again (is microg dashboard still running?)");
    setTimeout(connect, 2000);
  };
}

function live(state, text) {
  const element = document.getElementById("live");
  element.className = `live ${state}`;
  element.textContent = text;
}

function receive(message) {
  if (message.type === "overview") {
    microg.overview = message;
    microg.error = null;
    draw(message);
    microg.updates += 1;
    live("on", `live · read ${new Date(message.read_at).toLocaleTimeString()}`);
  } else if (message.type === "error") {
    microg.error = message.message;
    live("off", `cannot read the study: ${message.message}`);
  } else if (message.type === "view") {
    const opened = (microg.views[message.session] || {}).window;
    microg.views[message.session] = { ...message, window: opened };
    if (message.url && opened) opened.location.href = message.url;
    else if (opened) opened.close();
    if (microg.overview) drawSessions(microg.overview);
  }
}

function draw(o) {
  document.title = `microg: ${o.study.name}`;
  document.getElementById("title").textContent = `${o.study.name}` + (o.study.station ? ` (station ${o.study.station})` : "")
    + ` · protocol ${o.study.protocol}` + (o.study.archived ? " · read only (an archive)" : "");
  drawIntegrity(o);
  drawEnrolment(o);
  drawSessions(o);
  drawResults(o);
  drawQuestionnaires(o);
  drawStations(o);
  drawExport(o);
}

function drawIntegrity(o) {
  const element = document.getElementById("integrity");
  const record = o.integrity.record;
  const problems = [...new Set([...o.integrity.opened, ...(record && !record.sound ? record.problems : [])])];
  if (problems.length) {
    element.className = "integrity damaged";
    element.innerHTML = `The study is damaged (${problems.length} problem${problems.length > 1 ? "s" : ""}`
      + (record ? `; last check: ${esc(record.check)} at ${esc(when(record.checked_at))}` : "")
      + `). Keep the study folder as it is and see: <span class="command">microg study check ${esc(o.study.folder)}</span>`
      + `<ul>${problems.map((p) => `<li>${esc(p)}</li>`).join("")}</ul>`;
  } else {
    element.className = "integrity sound";
    element.textContent = record ? `Sound: last check (${record.check === "full" ? "microg study check" : "on open"}) `
      + `at ${when(record.checked_at)}` : "Sound when the dashboard opened it (no check recorded beside the study)";
  }
}

function drawEnrolment(o) {
  const e = o.enrolment;
  const filled = (n, of) => `<span class="bar"><span style="width:${Math.min(100, 100 * n / of)}%"></span></span>`;
  const rows = e.groups.map((g) => `<tr data-group="${esc(g.code)}"><td>${esc(g.code)} (${esc(g.name)})</td>`
    + `<td class="number"><span class="active">${g.active}</span> / ${g.size}</td><td class="meter">${filled(g.active, g.size)}</td>`
    + `<td class="number">${g.withdrawn}</td>`
    + `<td class="by">${Object.entries(g.by).map(([k, n]) => `${esc(k)} ${n}`).join(", ") || "–"}</td></tr>`);
  document.getElementById("enrolment").innerHTML = (e.balance === "gender" ? `<p class="note">The assignment `
    + `balances gender across the groups.</p>` : "") + `<table><thead><tr><th>group</th><th class="number">active / `
    + `target</th><th class="meter"></th><th class="number">withdrawn</th><th>by gender</th></tr></thead><tbody>${rows.join("")}</tbody>`
    + `<tfoot><tr><td>all</td><td class="number"><span id="enrolled">${e.active}</span> / ${e.target}</td>`
    + `<td class="meter">${filled(e.active, e.target)}</td><td class="number">${e.withdrawn}</td><td></td></tr></tfoot></table>`;
}

function progress(s) {
  const r = s.running;
  if (!r) return s.phase ? `in ${esc(s.phase)}` : "";
  const place = r.places ? ` · place ${Math.min(r.places_done + 1, r.places)} of ${r.places}` : "";
  return `${esc(r.phase)} · task ${r.task + 1} of ${r.of}: ${esc(r.object_name)} (${esc(r.interaction)})`
    + (r.run > 1 ? `, run ${r.run}` : "") + ` · ${esc(r.stage || "starting")}${place} · ${r.attempts} drop`
    + `${r.attempts === 1 ? "" : "s"} · <span class="elapsed">${fixed(r.elapsed_s, 1)}</span> s, `
    + `<span class="frames">${r.frames}</span> frames`;
}

function quality(s) {
  const q = s.quality;
  const parts = [];
  if (q.rate_hz != null) {
    const low = q.rate_hz < LOW_RATE * q.tracking_rate;
    parts.push(`<span class="${low ? "low" : ""}">${fixed(q.rate_hz, 0)} / ${fixed(q.tracking_rate, 0)} Hz</span>`);
  }
  if (q.guard) {
    const shown = GUARD_SHOWN.filter(([name]) => q.guard[name]).map(([name, label]) => `${q.guard[name]} ${label}`);
    parts.push(shown.length ? `guard: ${shown.join(", ")}` : "guard: nothing found");
  }
  const statuses = [["timeouts", "timed out"], ["skipped", "skipped"], ["aborted", "aborted"],
                    ["interrupted_runs", "runs cut off"]].filter(([k]) => q[k]).map(([k, label]) => `${q[k]} ${label}`);
  if (statuses.length) parts.push(`<span class="low">${statuses.join(", ")}</span>`);
  const d = q.display;
  if (d) {
    const shown = [];
    if (d.quality) shown.push(`scale ${fixed(d.quality.render_scale)}` + (d.quality.gpu_ms != null ? `, ${fixed(d.quality.gpu_ms, 1)} ms a frame` : ""));
    if (d.clock) shown.push(`clock ±${fixed(d.clock.spread_ms, 1)} ms`);
    if (d.latency) shown.push(`+${fixed(d.latency.added_latency_ms, 0)} ms added`);
    parts.push(`page: ${shown.join(", ")}`);
  }
  return parts.join(" · ");
}

function viewCell(o, s) {
  const view = microg.views[s.id];
  if (view && view.url) return `<a href="${esc(view.url)}" target="_blank" rel="noopener">open view</a>`;
  if (view && view.why) {
    return `<span class="low">${esc(view.why)}</span>` + (view.command ? `<br><span class="command">${esc(view.command)}</span>` : "");
  }
  if (view && view.asked) return "starting…";
  return `<button class="view" data-session="${s.id}">view</button>`;
}

function drawSessions(o) {
  const sessions = Object.fromEntries(o.sessions.map((s) => [s.id, s]));
  const rows = [];
  for (const p of o.participants) {
    const who = `<td>${esc(p.id)}</td><td>${esc(p.group)}</td><td>${esc(p.gender)}</td>`;
    const mine = p.sessions.map((id) => sessions[id]);
    if (!mine.length) {
      const state = p.status === "withdrawn" ? `<span class="status withdrawn">withdrawn</span>`
        : p.station ? `at station ${esc(p.station)}` : "no session yet";
      rows.push(`<tr data-participant="${esc(p.id)}">${who}<td></td><td>${state}</td><td colspan="4"></td></tr>`);
    }
    for (const s of mine) {
      const status = p.status === "withdrawn" ? "withdrawn" : s.status;
      const where = s.station ? ` · station ${esc(s.station)}${s.merged_at ? ", merged" : ""}` : "";
      const answered = s.answers_expected ? `${s.answers} / ${s.answers_expected}` : `${s.answers}`;
      rows.push(`<tr data-participant="${esc(p.id)}" data-session="${s.id}" data-status="${esc(status)}">${who}`
        + `<td class="session">${o.study.program ? `${esc(s.name)}<br>${esc(s.date)}` : s.id}</td><td class="where"><span class="status ${esc(status)}">${esc(status)}</span> · ${s.done} of ${s.tasks} tasks`
        + `${where}<br><span class="progress">${progress(s)}</span></td>`
        + `<td class="quality">${quality(s)}</td><td class="number answers">${answered}</td>`
        + `<td>${esc(s.input)}${s.resumes ? ` · resumed ${s.resumes}×` : ""}</td><td>${viewCell(o, s)}</td></tr>`);
    }
    if (p.next) {  // a training program's next session: due on its date, or overdue
      rows.push(`<tr data-participant="${esc(p.id)}" data-next="${esc(p.next.session)}">${who}`
        + `<td class="session">${esc(p.next.session)}</td><td class="where"><span class="status ${esc(p.next.state)}">`
        + `${esc(p.next.state)}</span> · due on ${esc(p.next.due)}</td><td colspan="4"></td></tr>`);
    }
  }
  document.getElementById("sessions").innerHTML = rows.length ? `<table><thead><tr><th>participant</th><th>group</th>`
    + `<th>gender</th><th>session</th><th>where it stands</th><th>data quality</th><th class="number">answers</th>`
    + `<th>input</th><th></th></tr></thead>`
    + `<tbody>${rows.join("")}</tbody></table>` : `<p class="empty">No participant yet: microg participant add ${esc(o.study.folder)} …</p>`;
}

function askView(session) {
  const opened = window.open("about:blank", "_blank");  // now, in the click: a window opened later is blocked
  microg.views[session] = { asked: true, window: opened };
  socket.send(JSON.stringify({ type: "view", session }));
  drawSessions(microg.overview);
}

document.addEventListener("click", (event) => {
  const button = event.target.closest("button.view");
  if (button) askView(Number(button.dataset.session));
});

function chartData(o, phase, measure) {
  const mine = o.results.points.filter((p) => p.phase === phase).map((p) => p.object);
  const objects = [...new Set([...o.study.objects, ...mine])].filter((code) => mine.includes(code));
  const groups = o.study.groups;
  const offset = (g) => (groups.indexOf(g) - (groups.length - 1) / 2) * 0.25;
  const datasets = [];
  groups.forEach((group, k) => {
    const colour = COLOURS[k % COLOURS.length];
    const points = o.results.points.filter((p) => p.phase === phase && p.group === group && p[measure] != null)
      .map((p, i) => ({ x: objects.indexOf(p.object) + offset(group) + ((i % 5) - 2) * 0.02, y: p[measure],
                        participant: p.participant }));
    const means = o.results.means.filter((m) => m.phase === phase && m.group === group && m[measure] != null)
      .map((m) => ({ x: objects.indexOf(m.object) + offset(group), y: m[measure] }));
    datasets.push({ label: `group ${group}`, data: points, backgroundColor: `${colour}99`, borderColor: colour,
                    pointRadius: 3.5, showLine: false });
    datasets.push({ label: `group ${group} mean`, data: means, borderColor: colour, backgroundColor: colour,
                    pointStyle: "line", pointRadius: 13, pointBorderWidth: 3, showLine: false });
  });
  return { objects, datasets };
}

function chart(id, o, phase, measure, title) {
  const { objects, datasets } = chartData(o, phase, measure);
  const names = o.study.object_names;
  let drawn = microg.charts[id];
  const canvas = document.getElementById(id);
  if (drawn && drawn.canvas !== canvas) {
    drawn.destroy();
    drawn = null;
  }
  const options = {
    animation: false, responsive: true, maintainAspectRatio: false,
    plugins: { legend: { labels: { filter: (item) => !item.text.endsWith("mean"), boxWidth: 10 } },
               title: { display: true, text: title },
               tooltip: { callbacks: { label: (c) => `${c.raw.participant || "mean"}: ${fixed(c.raw.y)}` } } },
    scales: { x: { type: "linear", min: -0.5, max: objects.length - 0.5,
                   afterBuildTicks: (axis) => { axis.ticks = objects.map((_, i) => ({ value: i })); },
                   ticks: { callback: (v) => names[objects[v]] || objects[v] || "" }, grid: { display: false } },
              y: { beginAtZero: true, title: { display: true, text: measure === "time_s" ? "s" : "drops" } } },
  };
  if (!drawn) {
    microg.charts[id] = new Chart(canvas, { type: "scatter", data: { datasets }, options });
  } else {
    drawn.data.datasets = datasets;
    drawn.options = options;
    drawn.update("none");
  }
}

function drawResults(o) {
  const element = document.getElementById("results");
  const phases = o.results.phases.filter((phase) => o.results.points.some((p) => p.phase === phase));
  const key = phases.join(",");
  if (element.dataset.phases !== key) {
    Object.values(microg.charts).forEach((c) => c.destroy());
    microg.charts = {};
    element.dataset.phases = key;
    element.innerHTML = phases.map((phase, i) => `<h3>${esc(phase)}</h3><div class="charts">`
      + `<div class="chart"><canvas id="chart-${i}-time"></canvas></div>`
      + `<div class="chart"><canvas id="chart-${i}-attempts"></canvas></div></div>`).join("")
      + `<details open><summary>means per phase, group and object</summary><div id="means" class="scroll"></div></details>`;
  }
  if (!phases.length) {
    element.innerHTML = `<p class="empty">No task measured yet.</p>`;
    element.dataset.phases = "";
    return;
  }
  phases.forEach((phase, i) => {
    chart(`chart-${i}-time`, o, phase, "time_s", `${phase}: completion time (s)`);
    chart(`chart-${i}-attempts`, o, phase, "attempts", `${phase}: attempts (drops)`);
  });
  const names = o.study.object_names;
  document.getElementById("means").innerHTML = `<table><thead><tr><th>phase</th><th>group</th><th>object</th>`
    + `<th class="number">tasks</th><th class="number">completed</th><th class="number">mean time (s)</th>`
    + `<th class="number">mean attempts</th></tr></thead><tbody>`
    + o.results.means.map((m) => `<tr data-phase="${esc(m.phase)}" data-group="${esc(m.group)}" data-object="${esc(m.object)}">`
      + `<td>${esc(m.phase)}</td><td>${esc(m.group)}</td><td>${esc(names[m.object] || m.object)} (${esc(m.object)})</td>`
      + `<td class="number">${m.tasks}</td><td class="number">${m.completed}</td>`
      + `<td class="number time">${fixed(m.time_s)}</td><td class="number attempts">${fixed(m.attempts)}</td></tr>`).join("")
    + `</tbody></table>`;
}

function drawQuestionnaires(o) {
  const element = document.getElementById("questionnaires");
  element.innerHTML = o.questionnaires.length ? `<table><thead><tr><th>instrument</th><th>administration</th>`
    + `<th>about</th><th class="number">answers</th><th class="number">sessions</th></tr></thead><tbody>`
    + o.questionnaires.map((q) => `<tr><td>${esc(q.instrument)}</td><td>${esc(q.administration)}</td>`
      + `<td>${esc(q.interaction || "–")}</td><td class="number">${q.answers}</td><td class="number">${q.sessions}</td></tr>`).join("")
    + `</tbody></table>` : `<p class="empty">No answer received yet.</p>`;
}

function drawStations(o) {
  const element = document.getElementById("stations");
  if (o.study.station) {
    element.innerHTML = `<p>This is station ${esc(o.study.station)}'s study: its sessions go back to the central study `
      + `with microg study merge.</p>`;
  } else {
    element.innerHTML = o.stations.length ? `<table><thead><tr><th>station</th><th>made</th><th>participants</th>`
      + `<th class="number">merged</th><th>taken back</th></tr></thead><tbody>`
      + o.stations.map((s) => `<tr><td>${esc(s.name)}</td><td>${esc(when(s.made_at))}</td>`
        + `<td>${s.participants.map(esc).join(", ")}</td><td class="number">${s.merged}</td>`
        + `<td>${s.given_up.map(esc).join(", ") || "–"}</td></tr>`).join("") + `</tbody></table>`
      : `<p class="empty">One station: no station was made (microg study station).</p>`;
  }
}

function drawExport(o) {
  const element = document.getElementById("export");
  const e = o.export;
  if (!e) {
    element.innerHTML = `<p class="empty">No export in the study folder yet: microg export ${esc(o.study.folder)}</p>`;
    return;
  }
  const parts = [];
  if (e.folder) {
    const since = e.facts_since == null ? "" : e.facts_since > 0
      ? ` · <span class="low">the study has ${e.facts_since} more facts since: export again to include them</span>`
      : " · up to date with the study";
    parts.push(`<p>Last export: <span class="command">${esc(e.folder)}</span>, ${esc(when(e.written_at))}, ${e.files} files`
      + `${since}${e.damaged.length ? ` · <span class="bad">exported damaged</span>` : ""}</p>`);
  }
  parts.push(e.report ? `<p><a id="report" href="/report?token=${encodeURIComponent(token)}" target="_blank" rel="noopener">`
    + `Open the report</a> (${esc(e.report.path)}, ${esc(when(e.report.written_at))})</p>`
    : `<p class="empty">No report in the study folder: microg report ${esc(o.study.folder)}/${esc(e.folder || "export")} `
      + `--out ${esc(o.study.folder)}/report</p>`);
  element.innerHTML = parts.join("");
}

connect();
