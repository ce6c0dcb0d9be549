// hand-service view: the page. It reads the daemon's API token from the link (#token=...),
// reads the server's Server-Sent Events stream through fetch() (so that the token travels
// in an Authorization header, never in a URL), keeps the last WINDOW_S seconds of every
// signal and redraws the plots at most DRAW_HZ times a second, scrolling with the
// daemon's clock. The buttons POST /api/<request> with the same header.
"use strict";

const WINDOW_S = 10;
const DRAW_HZ = 30;
const PLOTS = [  // per finger: a plot per quantity, its series (wire name, label, colour, dash, width)
  // drawn in this order: the wide filtered line under the thin measured one, the dotted
  // truth and the dashed reference on top, so that four nearly equal traces stay apart
  {key: "angle", unit: "deg", series: [
    ["angle_filt_deg", "filtered", "#ffbb78", null, 5],
    ["angle_deg", "measured", "#1f77b4", null, 1],
    ["angle_true_deg", "true (simulated)", "#2ca02c", [2, 3], 2],
    ["angle_ref_deg", "reference", "#000", [8, 5], 1.5]]},
  {key: "tracking error", label: "error", unit: "deg", series: [  // computed here from the two columns
    ["error_deg", "reference − measured", "#d62728", null, 1.5],
    ["error_true_deg", "reference − true", "#2ca02c", [2, 3], 1.5]]},
  {key: "pressure", unit: "kPa", series: [
    ["pressure_cmd_kpa", "command", "#9467bd", null],
    ["pressure_meas_kpa", "measured", "#2ca02c", null]]},
  {key: "force", unit: "N", series: [
    ["force_est_n", "estimated", "#d62728", null],
    ["force_ref_n", "reference", "#555", [6, 4]]]},
];

const view = {  // also read by the browser test (tests/browser)
  token: null, auth: "unknown", frames: 0, lastT: null, state: null, draws: 0,
  fingers: [], data: {}, plots: [], arrivedAt: 0, ratePeriodS: 0.01,
  buttons: null,  // state -> the buttons it accepts (the daemon's state machine, via the status)
};
const DERIVED = {  // the tracking error's series: reference minus a measured angle
  error_deg: ["angle_ref_deg", "angle_deg"],
  error_true_deg: ["angle_ref_deg", "angle_true_deg"],
};
window.hsView = view;

const $ = (id) => document.getElementById(id);

function message(text, kind) {
  const m = $("message");
  m.textContent = text;
  m.className = kind || "";
}

function headers() {
  return {"Authorization": "Bearer " + view.token};
}

async function takeToken() {
  const match = /(?:^#|&)token=([0-9a-fA-F]+)/.exec(location.hash);
  const code = /(?:^#|&)code=([0-9a-fA-F]+)/.exec(location.hash);
  history.replaceState(null, "", location.pathname);  // the secret leaves the address bar
  if (match) {
    view.token = match[1];
  } else if (code) {  // the printed link's one-time code, for a session key of this page
    const reply = await fetch("/api/session", {method: "POST", cache: "no-store",
                                               headers: {"Authorization": "Bearer " + code[1]}});
    if (reply.ok) view.token = (await reply.json()).session;
    else message("this link was used already: give the daemon's API token", "refused");
  }
}

async function check() {
  const reply = await fetch("/api/check", {headers: headers(), cache: "no-store"});
  if (reply.status === 401) {
    view.auth = "refused";
    document.body.dataset.auth = "refused";
    message("refused: wrong or missing token (the daemon's api.token; `hand-service view` prints the link)",
            "refused");
    $("login").hidden = false;
    return false;
  }
  if (!reply.ok) {
    message("the view server answered " + reply.status, "error");
    return false;
  }
  view.auth = "ok";
  document.body.dataset.auth = "ok";
  $("login").hidden = true;
  return true;
}

// -- the stream -------------------------------------------------------------------------
async function stream() {
  for (;;) {
    try {
      const reply = await fetch("/stream", {headers: headers(), cache: "no-store"});
      if (reply.status === 401) { await check(); return; }
      const reader = reply.body.getReader();
      const decoder = new TextDecoder();
      let buffer = "";
      $("stream").textContent = "open";
      for (;;) {
        const {value, done} = await reader.read();
        if (done) break;
        buffer += decoder.decode(value, {stream: true});
        let end;
        while ((end = buffer.indexOf("\n\n")) >= 0) {
          const event = buffer.slice(0, end);
          buffer = buffer.slice(end + 2);
          if (event.startsWith("data: ")) onFrame(JSON.parse(event.slice(6)));
        }
      }
    } catch (err) {
      // the server went away: say so, and try again
    }
    $("stream").textContent = "closed; reconnecting";
    await new Promise((r) => setTimeout(r, 1000));
  }
}

function onFrame(frame) {
  view.frames += 1;
  const status = frame.status;
  if (status) showStatus(status);
  if (frame.ring_note) message(frame.ring_note, "");
  else if ($("message").className === "") message("");
  const signals = frame.signals;
  if (signals) {
    if (signals.state) showState(signals.state);
    append(signals);
  }
  $("stream").textContent = view.frames + " frames" + (frame.rows_missed ? ", " + frame.rows_missed +
                                                       " rows missed" : "");
}

function showState(state) {
  view.state = state;
  const s = $("state");
  s.textContent = state;
  s.className = "state " + state;
  enableButtons();
}

function enableButtons() {  // only what the state accepts; the E-stop always
  const accepted = view.buttons && view.buttons[view.state];
  document.querySelectorAll("#buttons [data-button]").forEach((b) => {
    b.disabled = !accepted || !accepted.includes(b.dataset.button);
    b.title = b.disabled ? b.dataset.button + " is not accepted in " + (view.state || "this state") : "";
  });
}

function fixed(x, digits) {
  return x === null || x === undefined ? "-" : Number(x).toFixed(digits);
}

function showStatus(st) {
  if (st.buttons) view.buttons = st.buttons;
  if (st.state) showState(st.state);
  if (st.rate_hz) view.ratePeriodS = 1 / st.rate_hz;
  $("t").textContent = fixed(st.t_s, 1) + " s";
  $("misses").textContent = st.deadline_misses;
  $("skipped").textContent = st.skipped_deadlines;
  $("tick").textContent = st.tick_us_p99 === null ? "-" : fixed(st.tick_us_p99, 0) + " us";
  const counts = Object.entries(st.faults || {}).map(([k, v]) => k + " x" + v).join(", ");
  $("faults").textContent = st.faults_total + (counts ? " (" + counts + ")" : "");
  const f = st.last_fault;
  $("fault").textContent = f ? "last fault: " + f.cause + (f.finger ? " on " + f.finger : "") +
    " at t " + fixed(f.t_s, 2) + " s" + (f.detail ? ": " + f.detail : "") : "";
  const rec = st.recording || {};
  $("recording").textContent = rec.active ? (rec.rows + " rows") : "off";
  if (st.fingers && st.fingers.join() !== view.fingers.join()) buildPlots(st.fingers);
}

// -- data and plots ---------------------------------------------------------------------
function buildPlots(fingers) {
  view.fingers = fingers.slice();
  view.plots.forEach((p) => p.plot.destroy());
  view.plots = [];
  view.data = {};
  const main = $("plots");
  main.textContent = "";
  const width = Math.max(200, Math.floor((main.clientWidth - 90) / PLOTS.length) - 8);
  for (const finger of fingers) {
    const row = document.createElement("section");
    row.className = "finger";
    row.dataset.finger = finger;
    const h = document.createElement("h2");
    h.textContent = finger;
    row.appendChild(h);
    main.appendChild(row);
    const columns = {t: []};
    PLOTS.forEach((p) => p.series.forEach(([name]) => { columns[name] = []; }));
    view.data[finger] = columns;
    for (const spec of PLOTS) {
      const box = document.createElement("div");
      box.className = "plot";
      box.dataset.quantity = spec.key;
      row.appendChild(box);
      const opts = {
        width, height: 130, legend: {show: true, live: false},
        cursor: {show: false}, pxAlign: 0,
        scales: {x: {time: false}},
        axes: [{size: 30, label: "t (s)", labelSize: 14},
               {size: 46, label: (spec.label || spec.key) + " (" + spec.unit + ")", labelSize: 14}],
        series: [{label: "t (s)"}].concat(spec.series.map(([, label, stroke, dash, width]) =>
          ({label, stroke, width: width || 1.5, dash: dash || undefined, points: {show: false}}))),
      };
      const plot = new uPlot(opts, [[]].concat(spec.series.map(() => [])), box);
      view.plots.push({finger, spec, plot});
    }
  }
}

function append(signals) {
  const t = signals.t_s;
  if (!t.length) return;
  for (const finger of view.fingers) {
    const columns = view.data[finger];
    const given = signals.fingers[finger];
    if (!columns || !given) continue;
    columns.t.push(...t);
    for (const name in given) if (columns[name]) columns[name].push(...given[name]);
    for (const [name, [ref, angle]] of Object.entries(DERIVED)) {
      const r = given[ref], a = given[angle];
      columns[name].push(...t.map((_, i) => (r && a && r[i] !== null && a[i] !== null ? r[i] - a[i] : null)));
    }
    const keepFrom = t[t.length - 1] - WINDOW_S - 1;
    let drop = 0;
    while (drop < columns.t.length && columns.t[drop] < keepFrom) drop++;
    if (drop > 0) for (const name in columns) columns[name].splice(0, drop);
  }
  view.lastT = t[t.length - 1];
  view.arrivedAt = performance.now();
}

let lastDraw = 0;
function draw(now) {
  requestAnimationFrame(draw);
  if (view.lastT === null || now - lastDraw < 1000 / DRAW_HZ - 2) return;
  lastDraw = now;
  // the daemon's clock, run on between frames (at most a tenth of a second past the last row)
  const tNow = view.lastT + Math.min(0.1, (now - view.arrivedAt) / 1000);
  for (const {finger, spec, plot} of view.plots) {
    const columns = view.data[finger];
    const data = [columns.t].concat(spec.series.map(([name]) => columns[name]));
    plot.batch(() => {
      plot.setData(data, true);
      plot.setScale("x", {min: tNow - WINDOW_S, max: tNow});
    });
  }
  view.draws += 1;
}

// -- buttons ----------------------------------------------------------------------------
async function press(button) {
  try {
    const reply = await fetch("/api/" + button, {method: "POST", headers: headers()});
    if (reply.status === 401) { await check(); return; }
    const answer = await reply.json();
    if (answer.ok) {
      message(button + ": " + (answer.result && answer.result.state ? answer.result.state : "done"), "");
      if (answer.result && answer.result.state) showState(answer.result.state);
    } else {
      message(button + ": " + answer.error, "error");
    }
  } catch (err) {
    message(button + ": the view server cannot be reached", "error");
  }
}

document.querySelectorAll("[data-button]").forEach((b) =>
  b.addEventListener("click", () => press(b.dataset.button)));

$("login").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  view.token = $("token").value.trim();
  if (await check()) stream();
});

(async () => {
  await takeToken();
  requestAnimationFrame(draw);
  if (!view.token) {
    $("login").hidden = false;
    message("give the daemon's API token to open the view", "");
    return;
  }
  if (await check()) stream();
})();
