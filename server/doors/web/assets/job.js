// A job's page: its state and progress, the force on the bottom plate drawn as the samples
// arrive (a Server-Sent Events stream that resumes where it broke off), and, once it has
// ended, its measurements with the peaks Pa and Pb marked, and its result files.
import { api, chart, compactTicks, drawHeader, el, fill, force, header, percent, progressBar, sig, stateBadge, when } from "./dembuf.js";

const id = Number(location.pathname.split("/").pop());
const status = document.getElementById("status");
const bar = progressBar();
// t: the axis, in ms after the first contact once it is known (as the PNG plots draw it),
// else from the release; tRun: from the release. Forces in N; pa, pb: null but at the peaks.
const t = [], tRun = [], plate = [], pa = [], pb = [];
let contactMs = null;  // the projectile's first contact (the first sample it feels a force)
let plot = null;
let redraw = 0;
let liveSamples = 0;  // those that came while the job was still running (not replayed)
let stage = "";  // what the job is doing, from its progress (the bed stage before any force)

const isFinal = (state) => state === "done" || state === "failed" || state === "cancelled";

function draw() {
  redraw = 0;
  if (!plot) {
    const axis = contactMs === null ? "t [ms]" : "time after first contact [ms]";
    plot = chart(document.getElementById("chart"), {
      scales: { x: { time: false } },
      axes: [{ label: axis }, { label: "plate force [N]", values: compactTicks, size: 60 }],
      series: [
        { label: axis, value: (u, v) => (v === null ? "–" : sig(v, 5)) },
        { label: "plate force", stroke: "#1f5fbf", width: 1.5, value: (u, v) => force(v) },
        { label: "Pa", stroke: "#c53030", width: 0, points: { show: true, size: 9, fill: "#c53030" }, value: (u, v) => force(v) },
        { label: "Pb", stroke: "#b7791f", width: 0, points: { show: true, size: 9, fill: "#b7791f" }, value: (u, v) => force(v) },
      ],
    }, [t, plate, pa, pb]);
  } else {
    plot.setData([t, plate, pa, pb]);
  }
  document.body.dataset.samples = t.length;
  document.body.dataset.contactMs = contactMs ?? "";
  // Before the impact there is no force to draw: the note says what the job is doing.
  document.getElementById("chart-note").textContent = t.length
    ? `${t.length.toLocaleString()} samples, up to ${sig(t[t.length - 1], 5)} ms` +
      (contactMs === null ? "" : ` after the first contact (at t = ${sig(contactMs, 5)} ms)`)
    : stage ? `no force yet: ${stage}` : "0 samples";
}

function drawSoon() {
  if (!redraw) redraw = requestAnimationFrame(draw);
}

/** The axis from the first contact on: every time so far moves, and the chart is drawn
 * again with its new label. */
function startAxisAt(ms) {
  if (contactMs === ms) return;
  contactMs = ms;
  for (let k = 0; k < t.length; k++) t[k] = tRun[k] - ms;
  if (plot) {
    plot.destroy();
    plot = null;
  }
  drawSoon();
}

function addSamples(batch) {
  if (batch.first !== t.length) return;  // (a batch seen before a reconnect)
  for (let k = 0; k < batch.t_s.length; k++) {
    const ms = batch.t_s[k] * 1e3;
    if (contactMs === null && batch.proj_force_z_N && batch.proj_force_z_N[k]) startAxisAt(ms);
    tRun.push(ms);
    t.push(contactMs === null ? ms : ms - contactMs);
    plate.push(batch.plate_force_N[k]);
    pa.push(null);
    pb.push(null);
  }
  if (!isFinal(document.body.dataset.state)) liveSamples += batch.t_s.length;
  document.body.dataset.liveSamples = liveSamples;
  drawSoon();
}

/** Marks a peak at the sample nearest its time. */
function markPeak(series, time_s) {
  if (time_s === null || time_s === undefined || t.length === 0) return;
  const target = time_s * 1e3;
  let best = 0;
  for (let k = 1; k < tRun.length; k++) if (Math.abs(tRun[k] - target) < Math.abs(tRun[best] - target)) best = k;
  series[best] = plate[best];
}

function showOverview(job) {
  document.title = `dembuf: job ${job.id} ${job.name}`;
  fill(document.getElementById("title"), `Job ${job.id}: ${job.name} `, stateBadge(job.state));
  document.body.dataset.state = job.state;
  bar.update(job.state, job.progress);
  const facts = [
    ["owner", job.owner],
    ["submitted", when(job.created_at)],
    ["started", when(job.started_at)],
    ["finished", when(job.finished_at)],
    // while it runs, how far it is; once done, where it ended
    ["simulated time", `${sig((job.summary ? job.summary.end_time_s : job.progress.sim_time_s) * 1e3, 5)} ms`],
    ["steps", (job.summary ? job.summary.steps : job.progress.steps)?.toLocaleString() || "–"],
    ["peak force so far", force(job.peak_plate_force_N)],
  ];
  if (job.sweep_id) facts.unshift(["sweep", el("a", { href: `/sweeps/${job.sweep_id}` }, `${job.sweep_id} (${job.sweep_values.join(", ")})`)]);
  const overview = document.getElementById("overview");
  fill(overview, bar, el("dl", { class: "facts" }, facts.filter(([, v]) => v !== "").map(([k, v]) => [el("dt", {}, k), el("dd", {}, v)])));
  if (job.error) overview.append(el("p", { class: "error" }, job.error));
}

function figure(name, value, raw) {
  return el("div", { class: "figure", dataset: { name, value: raw ?? "" } },
    el("div", { class: "name" }, name), el("div", { class: "value" }, value));
}

function showResults(job) {
  const s = job.summary;
  if (s) {
    // The summary's first contact is the run's own: the axis starts there.
    if (typeof s.first_contact_time_s === "number") startAxisAt(s.first_contact_time_s * 1e3);
    markPeak(pa, s.Pa_time_s);
    markPeak(pb, s.Pb_time_s);
    drawSoon();
    fill(document.getElementById("figures"),
      figure("P", force(s.P_N), s.P_N),
      figure("Pa (push)", force(s.Pa_N), s.Pa_N),
      figure("Pb (wave)", force(s.Pb_N), s.Pb_N),
      figure("peak plate force", force(s.peak_plate_force_N), s.peak_plate_force_N),
      figure("bare plate Pa0", force(s.reference_peak_N), s.reference_peak_N),
      figure("λ (buffer ratio)", percent(s.lambda), s.lambda),
      figure("crater depth", s.crater_depth_m === undefined ? "–" : `${sig(100 * s.crater_depth_m, 3)} cm`, s.crater_depth_m),
      // (bed_thickness_m: a summary of an earlier dembuf)
      figure("bed H", `${sig(100 * (s.measured_thickness_m ?? s.bed_thickness_m), 3)} cm`, s.measured_thickness_m ?? s.bed_thickness_m),
      figure("C0", sig(s.C0, 3), s.C0),
      // A bed of several species or layers: each layer as measured, from the plate up.
      ...(s.bed?.layers ?? []).map((layer, k) => figure(`layer ${k + 1}`,
        `${sig(100 * layer.thickness_m, 3)} cm, C0 ${sig(layer.C0, 3)}; ` +
        Object.entries(layer.beads).filter(([, n]) => n > 0).map(([name, n]) => `${n.toLocaleString()} ${name}`).join(", "),
        layer.thickness_m)),
      figure("beads", (s.beads || 0).toLocaleString(), s.beads),
      figure("steps", (s.steps || 0).toLocaleString(), s.steps),
      figure("wall time", `${sig(s.wall_time_s, 3)} s`, s.wall_time_s),
      figure("ended", s.end_reason || "–", s.end_reason));
  }
  const files = ["plate_force.csv", ...(s ? ["summary.json"] : []), ...job.files.map((f) => f.path)];
  fill(document.getElementById("files"), files.map((path) =>
    el("li", {}, el("a", { href: `/api/jobs/${job.id}/files/${path.split("/").map(encodeURIComponent).join("/")}` }, path))));
  document.getElementById("results").hidden = false;
}

function follow() {
  // EventSource reconnects by itself after a break, sending the last event id: the stream
  // resumes from the sample after it.
  const events = new EventSource(`/api/jobs/${id}/events`);
  events.addEventListener("samples", (e) => addSamples(JSON.parse(e.data)));
  events.addEventListener("progress", (e) => {
    const { state, progress } = JSON.parse(e.data);
    bar.update(state, progress);
    const now = state === "queued" ? "queued" : progress.stage;
    if (now !== stage) {
      stage = now;
      if (!t.length) drawSoon();
    }
    document.body.dataset.state = state;
    status.textContent = "";
  });
  events.addEventListener("end", async (e) => {
    events.close();
    document.body.dataset.expectedSamples = JSON.parse(e.data).samples;
    draw();
    try {
      const job = await api(`/api/jobs/${id}`);
      showOverview(job);
      showResults(job);
      await drawHeader();
      document.body.dataset.ended = "true";
    } catch (error) {
      status.textContent = error.message;
    }
  });
  events.addEventListener("gone", () => { events.close(); status.textContent = "this job is gone"; });
  events.addEventListener("revoked", (e) => {
    events.close();
    status.textContent = JSON.parse(e.data).error;
  });
  events.onerror = () => { if (events.readyState !== EventSource.CLOSED) status.textContent = "connection lost; reconnecting…"; };
}

async function start() {
  header();
  try {
    const job = await api(`/api/jobs/${id}`);
    showOverview(job);
    document.getElementById("scene").textContent = job.scene_toml;
    draw();
    follow();
    // The facts beside the chart (times, steps) now and then, until the job ends.
    const timer = setInterval(async () => {
      if (document.body.dataset.ended) return clearInterval(timer);
      try { showOverview(await api(`/api/jobs/${id}`)); } catch (error) { status.textContent = error.message; }
    }, 3000);
  } catch (error) {
    status.textContent = error.message;
  }
}

start();
