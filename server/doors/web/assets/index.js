// The job list: every job the user may see, newest first, with its state, progress and peak
// force, refreshed every two seconds; and the sweeps, with how many of their jobs are done.
import { api, el, every, fill, force, header, progressBar, stateBadge, when } from "./dembuf.js";

const jobRows = new Map();  // job id -> its row, kept so that progress bars move smoothly

function jobRow(job) {
  let row = jobRows.get(job.id);
  if (!row) {
    const bar = progressBar();
    row = el("tr", { dataset: { job: job.id } },
      el("td", { class: "num" }, el("a", { href: `/jobs/${job.id}` }, job.id)),
      el("td", {}, el("a", { href: `/jobs/${job.id}` }, job.name)),
      el("td", { class: "hide-narrow" }, job.owner),
      el("td", { class: "state-cell" }),
      el("td", {}, bar),
      el("td", { class: "num peak" }),
      el("td", { class: "num hide-narrow p" }),
      el("td", { class: "hide-narrow" }, when(job.created_at)));
    row.bar = bar;
    jobRows.set(job.id, row);
  }
  row.dataset.state = job.state;
  fill(row.querySelector(".state-cell"), stateBadge(job.state));
  row.bar.update(job.state, job.progress);
  row.querySelector(".peak").textContent = force(job.peak_plate_force_N);
  row.querySelector(".p").textContent = force(job.P_N);
  if (job.error) row.title = job.error;
  return row;
}

async function refreshJobs() {
  const { jobs } = await api("/api/jobs?limit=200");
  const body = document.querySelector("#jobs tbody");
  if (jobs.length === 0) fill(body, el("tr", {}, el("td", { colspan: 8, class: "empty" }, "no jobs yet: dembuf submit SCENE")));
  else fill(body, jobs.map(jobRow));
}

async function refreshSweeps() {
  const { sweeps } = await api("/api/sweeps?limit=100");
  const body = document.querySelector("#sweeps tbody");
  if (sweeps.length === 0) {
    fill(body, el("tr", {}, el("td", { colspan: 6, class: "empty" }, "no sweeps yet: dembuf sweep --vary FIELD=...")));
    return;
  }
  fill(body, sweeps.map((sweep) => {
    const done = sweep.jobs_by_state.done || 0;
    const bar = progressBar();
    const ended = done + (sweep.jobs_by_state.failed || 0) + (sweep.jobs_by_state.cancelled || 0);
    bar.update(ended === sweep.jobs_total ? "done" : "running",
      { stage: `${done} of ${sweep.jobs_total} done`, fraction: sweep.jobs_total ? done / sweep.jobs_total : 0 });
    return el("tr", { dataset: { sweep: sweep.id } },
      el("td", { class: "num" }, el("a", { href: `/sweeps/${sweep.id}` }, sweep.id)),
      el("td", {}, el("a", { href: `/sweeps/${sweep.id}` }, sweep.name)),
      el("td", { class: "hide-narrow" }, sweep.owner),
      el("td", {}, sweep.axes.map((a) => a.field).join(", ")),
      el("td", {}, bar),
      el("td", { class: "hide-narrow" }, when(sweep.created_at)));
  }));
}

header();
const status = document.getElementById("status");
every(2, refreshJobs, status);
every(5, refreshSweeps, status);
