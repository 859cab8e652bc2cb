// The database page: the paper's Figure 7 live (cutoff n against point count, with the
// fixed cutoff) and the histogram of solver calls per model (GET /v1/stats/cutoff).

import { el, getJson } from "./api.js";
import { plotBars, plotXY } from "./plots.js";

const REFRESH_MS = 3000;

export function databasePage(page, signal) {
  const scatter = el("canvas", { class: "plot", id: "cutoff-plot", style: "height: 320px" });
  const bars = el("canvas", { class: "plot", id: "solver-calls-plot" });
  const summary = el("p", { class: "hint", id: "cutoff-summary" });
  page.replaceChildren(
    el("h1", {}, "Database"),
    el("h2", {}, "Cutoff n against point count (the paper's Figure 7)"), summary, scatter,
    el("h2", {}, "Solver calls per model"), bars,
  );

  async function refresh() {
    const stats = await getJson("/v1/stats/cutoff");
    // The plot holds at most a few thousand of the models (every k-th by point count);
    // the count and the mean are over all of them.
    const plotted = stats.models.length < stats.ready_models ? ` (${stats.models.length} plotted)` : "";
    const mean = stats.mean_n === null ? 0 : stats.mean_n;
    summary.textContent = `${stats.ready_models} ready models${plotted}; mean adaptive n ${mean.toFixed(1)} against the fixed ${stats.fixed_n}.`;
    plotXY(scatter, [{ points: stats.models.map((m) => [m.n_points, m.cutoff.n]) }],
      { xLabel: "points", yLabel: "cutoff n", reference: { y: stats.fixed_n, label: `fixed n = ${stats.fixed_n}` } });
    plotBars(bars, stats.solver_calls.map((b) => [b.solver_calls, b.models]), { xLabel: "solver calls", yLabel: "models" });
  }

  // Every REFRESH_MS, or ten times as long as the last answer took (a large catalogue's
  // counts take a second): the page costs the service at most a tenth of one request slot.
  let timer = null;
  async function loop(first) {
    const started = performance.now();
    try {
      await refresh();
    } catch (error) {
      if (first) summary.textContent = error.message;
    }
    if (signal.aborted) return;
    const wait = Math.max(REFRESH_MS, 10 * (performance.now() - started));
    timer = setTimeout(() => loop(false), wait);
  }
  loop(true);
  signal.addEventListener("abort", () => clearTimeout(timer));
}
