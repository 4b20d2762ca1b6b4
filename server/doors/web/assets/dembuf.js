// What every page of dembufd shares: the API, building elements from data (never from HTML
// text), numbers in their units, the header, the progress bar and charts.

/** The API's answer as an object; throws an Error with the server's reason. */
export async function api(path) {
  const response = await fetch(path, { headers: { Accept: "application/json" } });
  if (response.status === 401) {
    location.assign("/login?next=" + encodeURIComponent(location.pathname));
    throw new Error("not logged in");
  }
  const body = await response.json().catch(() => ({}));
  if (!response.ok) throw new Error(body.error || `${path}: HTTP ${response.status}`);
  return body;
}

/** An element with attributes (and dataset, class, on* listeners) and children (text or nodes). */
export function el(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attributes)) {
    if (value === undefined || value === null) continue;
    if (key === "class") node.className = value;
    else if (key === "dataset") Object.assign(node.dataset, value);
    else if (key.startsWith("on")) node.addEventListener(key.slice(2), value);
    else node.setAttribute(key, value);
  }
  for (const child of children.flat(Infinity)) {
    if (child === undefined || child === null) continue;
    node.append(child instanceof Node ? child : String(child));
  }
  return node;
}

/** Replaces the children of a node. */
export function fill(node, ...children) {
  node.replaceChildren();
  for (const child of children.flat(Infinity)) if (child !== undefined && child !== null) node.append(child);
}

/** A number with `digits` significant digits, or a dash for none. */
export function sig(value, digits = 4) {
  if (value === null || value === undefined || !Number.isFinite(value)) return "–";
  return Number(value.toPrecision(digits)).toLocaleString("en-US", { maximumFractionDigits: 12 });
}

/** A force in N or kN. */
export function force(newtons) {
  if (newtons === null || newtons === undefined || !Number.isFinite(newtons)) return "–";
  return Math.abs(newtons) >= 1000 ? `${sig(newtons / 1000)} kN` : `${sig(newtons)} N`;
}

export function percent(fraction, digits = 3) {
  return fraction === null || fraction === undefined ? "–" : `${sig(100 * fraction, digits)} %`;
}

/** "2026-11-25T17:25:13Z" as the reader's local date and time; "" for none. */
export function when(utc) {
  if (!utc) return "";
  const date = new Date(utc);
  return Number.isNaN(date.getTime()) ? utc : date.toLocaleString();
}

export function stateBadge(state) {
  return el("span", { class: `state ${state}`, dataset: { state } }, state.replace("_", " "));
}

/** A progress bar with its label; update() it with a job's state and progress. */
export function progressBar() {
  const fillBar = el("div", { class: "fill" });
  const label = el("span", { class: "label" });
  const node = el("div", { class: "progress" }, el("div", { class: "track" }, fillBar), label);
  node.update = (state, progress) => {
    const final = state === "done" || state === "failed" || state === "cancelled";
    const fraction = state === "done" ? 1 : Math.min(Math.max(progress.fraction || 0, 0), 1);
    fillBar.style.width = `${(100 * fraction).toFixed(1)}%`;
    fillBar.style.background = `var(--${state === "preparing_bed" ? "preparing" : state})`;
    label.textContent = final ? state : `${progress.stage || state} ${Math.round(100 * fraction)}%`;
    node.dataset.fraction = fraction;
  };
  return node;
}

/** Axis ticks with thousands as "k" (5k for 5000): forces in N from a small bed to E2's. */
export function compactTicks(u, ticks) {
  return ticks.map((v) => (Math.abs(v) >= 1000 ? `${sig(v / 1000)}k` : sig(v)));
}

/** The bar at the top: the server, the user, and a way out for those logged in; kept fresh. */
export async function header() {
  const info = await drawHeader();
  setInterval(drawHeader, 5000);
  return info;
}

/** Draws the bar at the top again now (after a change it shows, such as a job's end). */
export async function drawHeader() {
  const bar = document.querySelector("header.bar");
  try {
    const info = await api("/api/server");
    const user = info.user.token
      ? el("span", { class: "user" }, `${info.user.name}${info.user.admin ? " (admin)" : ""}`,
          el("form", { method: "post", action: "/logout" }, el("button", { type: "submit" }, "log out")))
      : el("span", { class: "user" }, "local access");
    fill(bar, el("a", { class: "home", href: "/" }, "dembuf"),
      el("span", { class: "server" },
        `${info.host} · dembufd ${info.version} · ${info.running} running, ${info.queue_depth} queued`),
      user);
    return info;
  } catch (error) {
    fill(bar, el("a", { class: "home", href: "/" }, "dembuf"), el("span", { class: "server" }, error.message));
    return null;
  }
}

/** Shows an error in place of a page's content. */
export function showError(node, error) {
  fill(node, el("p", { class: "error", role: "alert" }, error.message || String(error)));
}

/** Calls `work` now and every `seconds`, until it returns false; errors are shown in `status`. */
export function every(seconds, work, status) {
  let timer = null;
  const tick = async () => {
    let again = true;
    try {
      again = (await work()) !== false;
      if (status) status.textContent = "";
    } catch (error) {
      if (status) status.textContent = error.message;
    }
    if (again) timer = setTimeout(tick, seconds * 1000);
  };
  tick();
  return () => clearTimeout(timer);
}

/** A uPlot chart that fills its container's width, redrawn when the window changes. */
export function chart(container, options, data) {
  const size = () => ({
    width: Math.max(container.clientWidth, 240),
    height: Math.round(Math.min(Math.max(container.clientWidth * 0.45, 220), 420)),
  });
  const plot = new uPlot({ ...options, ...size() }, data, container);
  window.addEventListener("resize", () => plot.setSize(size()));
  return plot;
}

/** A y range (for uPlot's scales) that holds every point with its error bar, and a margin. */
export function rangeWithBars(bars) {
  return (u) => {
    let low = Infinity, high = -Infinity;
    for (let s = 1; s < u.series.length; s++) {
      const half = bars(s) || [];
      u.data[s].forEach((y, i) => {
        if (y === null || y === undefined) return;
        const h = half[i] || 0;
        low = Math.min(low, y - h);
        high = Math.max(high, y + h);
      });
    }
    if (!Number.isFinite(low)) return [0, 1];
    const pad = 0.08 * (high - low || Math.abs(high) || 1);
    return [low - pad, high + pad];
  };
}

/**
 * A uPlot plugin drawing error bars: `bars(seriesIndex)` gives, per data index, the half
 * width (null for none) of series seriesIndex's points.
 */
export function errorBars(bars) {
  return {
    hooks: {
      draw: (u) => {
        const ctx = u.ctx;
        ctx.save();
        ctx.beginPath();
        ctx.rect(u.bbox.left, u.bbox.top, u.bbox.width, u.bbox.height);
        ctx.clip();
        ctx.lineWidth = Math.max(1, devicePixelRatio);
        for (let s = 1; s < u.series.length; s++) {
          const half = bars(s);
          if (!half || !u.series[s].show) continue;
          ctx.strokeStyle = u.series[s].stroke();
          const xs = u.data[0], ys = u.data[s];
          for (let i = 0; i < xs.length; i++) {
            if (ys[i] === null || half[i] === null || half[i] === undefined) continue;
            const x = u.valToPos(xs[i], "x", true);
            const top = u.valToPos(ys[i] + half[i], u.series[s].scale, true);
            const bottom = u.valToPos(ys[i] - half[i], u.series[s].scale, true);
            const cap = 4 * devicePixelRatio;
            ctx.beginPath();
            ctx.moveTo(x, top); ctx.lineTo(x, bottom);
            ctx.moveTo(x - cap, top); ctx.lineTo(x + cap, top);
            ctx.moveTo(x - cap, bottom); ctx.lineTo(x + cap, bottom);
            ctx.stroke();
          }
        }
        ctx.restore();
      },
    },
  };
}
