// A sweep's page: P and lambda against the swept field, with the seeds' spread as error bars,
// filling in as the sweep's jobs finish (the points are read again every three seconds).
import { api, chart, compactTicks, drawHeader, el, every, errorBars, fill, force, header, percent, progressBar, rangeWithBars, sig, stateBadge } from "./dembuf.js";

const id = Number(location.pathname.split("/").pop());
const status = document.getElementById("status");
const bar = progressBar();
const charts = {};  // "P" and "lambda": { plot, sd }

/** How the swept field is shown: values in metres below one as cm. */
function axisOf(axis) {
  const values = axis.values.map(Number);
  const numeric = values.every(Number.isFinite);
  const cm = numeric && axis.unit === "m" && values.every((v) => Math.abs(v) < 1);
  return {
    field: axis.field,
    numeric,
    scale: cm ? 100 : 1,
    label: cm ? `${axis.field}, in cm` : `${axis.field}${axis.unit ? ` [${axis.unit}]` : ""}`,
    values: axis.values,
  };
}

/**
 * The chart data of a metric: x (the swept field; its index for a field that is not a number),
 * one series per combination of the other fields, and each series' sd.
 */
function series(sweep, x, metric, scale) {
  const others = sweep.axes.filter((a) => a.field !== "bed.seed" && a.field !== x.field).map((a) => a.field);
  const xs = x.numeric ? [...new Set(x.values.map(Number))].sort((a, b) => a - b) : x.values.map((_, i) => i);
  const groups = new Map();
  for (const point of sweep.points) {
    const key = others.map((f) => `${f}=${point[f]}`).join(", ") || "mean over the seeds";
    if (!groups.has(key)) groups.set(key, { mean: xs.map(() => null), sd: xs.map(() => null) });
    const at = x.field === "" ? 0
      : x.numeric ? xs.indexOf(Number(point[x.field])) : x.values.indexOf(point[x.field]);
    const mean = point[metric], sd = point[`${metric}_sd`];
    if (at < 0 || mean === null) continue;
    groups.get(key).mean[at] = mean * scale;
    groups.get(key).sd[at] = sd === null ? null : sd * scale;
  }
  return { xs: xs.map((v) => (x.numeric ? v * x.scale : v)), groups };
}

const colours = ["#1f5fbf", "#c53030", "#2f855a", "#b7791f", "#6b46c1", "#2c7a7b"];

function plotMetric(name, container, sweep, x, metric, scale, yLabel) {
  const { xs, groups } = series(sweep, x, metric, scale);
  const keys = [...groups.keys()];
  const data = [xs, ...keys.map((k) => groups.get(k).mean)];
  const sd = [null, ...keys.map((k) => groups.get(k).sd)];
  const shape = keys.join("|");
  if (charts[name] && charts[name].shape === shape) {
    charts[name].sd = sd;
    charts[name].plot.setData(data);
    return;
  }
  if (charts[name]) charts[name].plot.destroy();
  fill(container);
  const entry = { sd, shape };
  entry.plot = chart(container, {
    scales: {
      // a margin on both sides, for the end points' error bars
      x: { time: false, range: (u, min, max) => [min - 0.04 * (max - min || 1), max + 0.04 * (max - min || 1)] },
      y: { range: rangeWithBars((s) => entry.sd[s]) },
    },
    axes: [
      { label: x.label, values: x.numeric ? undefined : (u, ticks) => ticks.map((i) => x.values[i] ?? "") },
      { label: yLabel, values: compactTicks, size: 60 },
    ],
    series: [{ label: x.label }, ...keys.map((k, i) => ({
      label: k,
      stroke: colours[i % colours.length],
      width: 1.5,
      spanGaps: true,
      points: { show: true, size: 7, fill: colours[i % colours.length] },
      value: (u, v) => (v === null ? "–" : sig(v)),
    }))],
    plugins: [errorBars((s) => entry.sd[s])],
  }, data);
  charts[name] = entry;
}

// A metric of a point (its mean, and its sd when there are two runs or more).
function cell(point, metric, format) {
  const mean = point[metric], sd = point[`${metric}_sd`];
  if (mean === null) return el("td", { class: "num" }, "–");
  return el("td", { class: "num" }, sd === null ? format(mean) : `${format(mean)} ± ${format(sd)}`);
}

async function refresh() {
  const sweep = await api(`/api/sweeps/${id}`);
  document.title = `dembuf: sweep ${sweep.id} ${sweep.name}`;
  fill(document.getElementById("title"), `Sweep ${sweep.id}: ${sweep.name}`);
  const done = sweep.jobs_by_state.done || 0;
  const ended = done + (sweep.jobs_by_state.failed || 0) + (sweep.jobs_by_state.cancelled || 0);
  const finished = ended === sweep.jobs_total;
  bar.update(finished ? "done" : "running",
    { stage: `${done} of ${sweep.jobs_total} done`, fraction: sweep.jobs_total ? done / sweep.jobs_total : 0 });
  document.body.dataset.done = done;
  document.body.dataset.points = sweep.points.filter((p) => p.P_N !== null).length;
  fill(document.getElementById("overview"), bar,
    el("dl", { class: "facts" },
      el("dt", {}, "owner"), el("dd", {}, sweep.owner),
      sweep.axes.map((a) => [el("dt", {}, a.field), el("dd", {}, a.values.join(", "))]),
      el("dt", {}, "jobs"), el("dd", {}, Object.entries(sweep.jobs_by_state).map(([s, n]) => `${n} ${s}`).join(", ")),
      // Hc only where P levels off; else the note says by how much it still changes.
      sweep.critical_thickness ? [el("dt", {}, "Hc"), el("dd", {}, sweep.Hc_m !== null
        ? `${sig(100 * sweep.Hc_m, 3)} cm (plateau P ${force(sweep.critical_thickness.plateau_P_N)})`
        : sweep.critical_thickness.note)] : []));

  const swept = sweep.axes.filter((a) => a.field !== "bed.seed");
  // (a sweep of seeds only has one point)
  const x = axisOf(swept[0] || { field: "", values: ["all seeds"], unit: "" });
  plotMetric("P", document.getElementById("p-chart"), sweep, x, "P_N", 1, "P [N]");
  plotMetric("lambda", document.getElementById("lambda-chart"), sweep, x, "lambda", 100, "λ [%]");

  const pointsTable = document.getElementById("points");
  fill(pointsTable.tHead, el("tr", {}, swept.map((a) => el("th", {}, a.field)),
    el("th", { class: "num" }, "runs"), el("th", { class: "num" }, "P"), el("th", { class: "num" }, "λ"),
    el("th", { class: "num" }, "crater depth"), el("th", { class: "num" }, "C0")));
  fill(pointsTable.tBodies[0], sweep.points.map((p) => el("tr", {},
    swept.map((a) => el("td", {}, p[a.field])),
    el("td", { class: "num" }, `${p.P_N_n} of ${p.runs}`),
    cell(p, "P_N", force), cell(p, "lambda", (v) => percent(v)),
    cell(p, "crater_depth_m", (v) => `${sig(100 * v, 3)} cm`), cell(p, "C0", (v) => sig(v, 3)))));

  const jobsTable = document.getElementById("jobs");
  fill(jobsTable.tHead, el("tr", {}, el("th", { class: "num" }, "job"), sweep.axes.map((a) => el("th", {}, a.field)), el("th", {}, "state")));
  fill(jobsTable.tBodies[0], sweep.jobs.map((j) => el("tr", {},
    el("td", { class: "num" }, el("a", { href: `/jobs/${j.id}` }, j.id)),
    j.values.map((v) => el("td", {}, v)), el("td", {}, stateBadge(j.state)))));
  if (finished) await drawHeader();
  document.body.dataset.finished = finished;
  return !finished;
}

header();
every(3, refresh, status);
