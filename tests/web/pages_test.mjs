// The web pages of a running dembufd, in headless Chromium: a job's force arriving live and
// drawn, its final peak as summary.json has it, the job list showing it done, a sweep's
// points drawn, and, on a daemon serving beyond loopback, no page without a token.
//
// Usage: node pages_test.mjs [--base URL --job ID --summary FILE --sweep ID --points N
//          --min-live N] [--protected URL --token TOKEN] [--screenshots DIR]
// Each part runs when its arguments are given. The summary file may appear while the job
// runs (it is waited for). Exits 0 when every check passes; prints each check.
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { parseArgs } from "node:util";
import puppeteer from "puppeteer-core";

const { values: args } = parseArgs({
  options: {
    base: { type: "string" },
    job: { type: "string" },
    summary: { type: "string" },
    sweep: { type: "string" },
    points: { type: "string" },
    "min-live": { type: "string", default: "20" },
    protected: { type: "string" },
    token: { type: "string" },
    screenshots: { type: "string" },
    browser: { type: "string", default: "/usr/bin/chromium" },
  },
});

let failures = 0;
function check(ok, what, detail = "") {
  console.log(`${ok ? "ok  " : "FAIL"} ${what}${detail ? `: ${detail}` : ""}`);
  if (!ok) failures++;
}

// The pages' own errors (a script that throws) fail the test too.
function watchErrors(page, name) {
  page.on("pageerror", (error) => check(false, `${name}: no script error`, error.message));
  page.on("console", (message) => {
    if (message.type() === "error") console.log(`  (${name} console: ${message.text()})`);
  });
}

/** How many pixels of the page's first chart canvas are drawn (not transparent). */
async function drawnPixels(page, selector) {
  return page.$eval(selector, (container) => {
    const canvas = container.querySelector("canvas");
    if (!canvas || canvas.width === 0) return 0;
    const data = canvas.getContext("2d").getImageData(0, 0, canvas.width, canvas.height).data;
    let drawn = 0;
    for (let k = 3; k < data.length; k += 4) if (data[k] !== 0) drawn++;
    return drawn;
  });
}

/** The summary.json file once it is there (the test fetches it when the job ends). */
async function summaryFile(path) {
  for (let k = 0; k < 600 && !existsSync(path); k++) await new Promise((r) => setTimeout(r, 100));
  return JSON.parse(readFileSync(path, "utf8"));
}

async function screenshot(page, name) {
  if (!args.screenshots) return;
  mkdirSync(args.screenshots, { recursive: true });
  await page.screenshot({ path: join(args.screenshots, name), fullPage: false });
  console.log(`     screenshot ${join(args.screenshots, name)}`);
}

const profile = mkdtempSync(join(tmpdir(), "dembuf-chromium-"));
const browser = await puppeteer.launch({
  executablePath: args.browser,
  headless: true,
  userDataDir: profile,
  // As root in a container: no sandbox; a small /dev/shm; and nothing fetched from outside
  // (the machine may have no network, and the pages must not need one).
  args: ["--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-quic"],
});

try {
  if (args.job) await jobPages();
  if (args.protected) await protectedPages();
} catch (error) {
  check(false, "the test ran to its end", error.stack || String(error));
} finally {
  await browser.close();
  rmSync(profile, { recursive: true, force: true });
}
console.log(failures === 0 ? "web pages: every check passed" : `web pages: ${failures} checks failed`);
process.exit(failures === 0 ? 0 : 1);

async function jobPages() {
  // --- the job's page, opened while the job runs --------------------------------------------
  const page = await browser.newPage();
  await page.setViewport({ width: 1100, height: 900 });
  watchErrors(page, "job page");
  const outside = [];
  page.on("request", (request) => {
    if (!request.url().startsWith(args.base) && !request.url().startsWith("data:")) outside.push(request.url());
  });
  await page.goto(`${args.base}/jobs/${args.job}`, { waitUntil: "domcontentloaded" });
  console.log("     job page open");  // (the test starts the job when it reads this)
  if (args.screenshots) {
    // A picture while the impact runs, when the job lasts long enough to be caught.
    const running = await page.waitForFunction((min) => document.body.dataset.state === "running" &&
      Number(document.body.dataset.liveSamples) >= min, { timeout: 900_000 }, Number(args["min-live"]))
      .catch(() => null);
    if (running) await screenshot(page, "web_job_live.png");
  }
  await page.waitForSelector('body[data-ended="true"]', { timeout: 300_000 });
  const seen = await page.$eval("body", (b) => ({ ...b.dataset }));
  check(Number(seen.liveSamples) >= Number(args["min-live"]),
    `at least ${args["min-live"]} samples arrived live, while the job ran`, `${seen.liveSamples} of ${seen.samples}`);
  check(Number(seen.samples) === Number(seen.expectedSamples) && Number(seen.samples) > 0,
    "every sample of the series arrived once", `${seen.samples} drawn, the stream ended at ${seen.expectedSamples}`);
  check(seen.state === "done", "the page shows the job done", seen.state);
  const summary = await summaryFile(args.summary);
  const pixels = await drawnPixels(page, "#chart");
  check(pixels > 2000, "the force chart is drawn", `${pixels} pixels`);
  // Its time axis starts at the first contact, as the PNG plots' does.
  const contact = await page.$eval("body", (b) => Number(b.dataset.contactMs));
  check(Math.abs(contact - summary.first_contact_time_s * 1e3) < 1e-6,
    "the chart's time is after the first contact", `${contact} ms against ${summary.first_contact_time_s * 1e3}`);
  const axis = await page.$eval("#chart", (c) => c.textContent);
  check(axis.includes("time after first contact [ms]"), "the time axis says from what", axis.slice(0, 200));
  const figure = (name) => page.$eval(`.figure[data-name="${name}"]`, (f) => f.dataset.value);
  const peak = await figure("peak plate force");
  check(Number(peak) === summary.peak_plate_force_N, "the peak on the page is summary.json's",
    `${peak} against ${summary.peak_plate_force_N}`);
  const p = await figure("P");
  check(Number(p) === summary.P_N, "P on the page is summary.json's", `${p} against ${summary.P_N}`);
  const files = await page.$$eval("#files a", (links) => links.map((a) => a.textContent));
  check(files.includes("plate_force.csv") && files.includes("summary.json"),
    "the result files are linked", files.join(", "));
  await screenshot(page, "web_job.png");
  check(outside.length === 0, "nothing was loaded from outside the daemon", outside.join(", "));

  // --- the job list shows it done ------------------------------------------------------------
  const list = await browser.newPage();
  watchErrors(list, "job list");
  await list.goto(`${args.base}/`, { waitUntil: "domcontentloaded" });
  const row = await list.waitForSelector(`tr[data-job="${args.job}"][data-state="done"]`, { timeout: 30_000 })
    .catch(() => null);
  check(row !== null, `the job list shows job ${args.job} done`);

  // --- the sweep's page: its points drawn as they finish -------------------------------------
  const sweep = await browser.newPage();
  await sweep.setViewport({ width: 1100, height: 1000 });
  watchErrors(sweep, "sweep page");
  await sweep.goto(`${args.base}/sweeps/${args.sweep}`, { waitUntil: "domcontentloaded" });
  await sweep.waitForSelector('body[data-finished="true"]', { timeout: 300_000 });
  const points = await sweep.$eval("body", (b) => Number(b.dataset.points));
  check(points === Number(args.points), `the sweep page has its ${args.points} points`, String(points));
  const sweepPixels = await drawnPixels(sweep, "#p-chart");
  check(sweepPixels > 2000, "the sweep's P chart is drawn", `${sweepPixels} pixels`);
  await screenshot(sweep, "web_sweep.png");
}

async function protectedPages() {
  // --- beyond loopback: the pages need a token -------------------------------------------------
  {
    const context = await browser.createBrowserContext();
    const guest = await context.newPage();
    watchErrors(guest, "login");
    const response = await guest.goto(`${args.protected}/`, { waitUntil: "domcontentloaded" });
    check(new URL(guest.url()).pathname === "/login", "without a token the job list is refused (sent to log in)",
      `${response.status()} ${guest.url()}`);
    const api = await guest.evaluate(async () => (await fetch("/api/jobs")).status);
    check(api === 401, "without a token the API answers 401", String(api));
    await guest.type("#token", "not-a-token");
    await Promise.all([guest.waitForNavigation(), guest.click('button[type="submit"]')]);
    check(new URL(guest.url()).pathname === "/login", "a wrong token is refused", guest.url());
    await guest.type("#token", args.token);
    await Promise.all([guest.waitForNavigation(), guest.click('button[type="submit"]')]);
    check(new URL(guest.url()).pathname === "/", "with a token the job list opens", guest.url());
    const user = await guest.waitForSelector("header .user", { timeout: 10_000 }).then((e) => e.evaluate((n) => n.textContent));
    check(user.includes("alice"), "the page names the user", user);
    const cookie = await guest.evaluate(() => document.cookie);
    check(!cookie.includes("dembuf_session"), "the session cookie is out of the scripts' reach (HttpOnly)");
    await context.close();
  }
}
