// A model page: the 3D point view coloured by the HKS at a chosen time, the cutoff, the
// eigenvalues, the timings, the most similar models and a side-by-side comparison.

import { ApiError, el, getJson, getPreview, modelLabel, sizeLabel, statusBadge } from "./api.js";
import { assemblyPanel, labelledCloud } from "./assemblies.js";
import { plotXY } from "./plots.js";
import { PointView, drawThumbnail, scaledColumn } from "./pointview.js";

const SIMILAR_K = 8;

function facts(model) {
  const cutoff = model.cutoff || {};
  const rows = [
    ["status", statusBadge(model.status)],
    ["external id", model.external_id || "-"],
    ["file", `${model.file.filename} (${model.file.format}, ${model.file.size} bytes)`],
    ["points", model.n_points ?? "-"],
    ["size (L x W x H)", sizeLabel(model.size) || "-"],
    ["cutoff n", cutoff.n ?? "-"],
    ["solver calls", cutoff.solver_calls ?? "-"],
    ["cutoff mode", cutoff.mode ?? "-"],
    ["metadata", JSON.stringify(model.metadata)],
  ];
  return el("table", { class: "facts", id: "facts" },
    rows.map(([name, value]) => el("tr", {}, el("th", {}, name), el("td", { "data-fact": name }, value))));
}

function timings(model) {
  const entries = Object.entries(model.timings || {});
  return el("table", { class: "facts", id: "timings" },
    entries.map(([stage, seconds]) => el("tr", {}, el("th", {}, stage), el("td", {}, `${seconds.toFixed(3)} s`))));
}

// A view of one model's preview with a time slider; returns {setTime}.
function viewBox(preview, title) {
  const canvas = el("canvas", { class: "view" });
  const box = el("div", { class: "viewbox" }, el("div", {}, title), canvas);
  return { box, canvas };
}

// The calibrated score in words ("copy", "same kind", "different kind"), when the
// descriptor has a calibration.
function likeness(result) {
  if (!result.likeness) return null;
  return el("span", {
    class: `likeness ${result.likeness.replace(" ", "-")}`, "data-likeness": result.likeness,
    title: `calibrated score ${result.calibrated_score.toFixed(4)}: the share of pairs of different kinds of part that score lower`,
  }, result.likeness);
}

// Result cards; buttons: [[label, onclick(result)], ...] on each card.
function cards(results, buttons = []) {
  return results.map((result) => {
    const thumb = el("canvas", {});
    getPreview(result.model.id)
      .then((preview) => drawThumbnail(thumb, preview, Math.floor(preview.times.length / 2)))
      .catch(() => thumb.replaceWith(el("div", { class: "hint" }, "no preview")));
    return el("div", { class: "card", "data-model-id": result.model.id },
      thumb,
      el("a", { href: `#/models/${result.model.id}` }, modelLabel(result.model)),
      el("div", { class: "scores" }, el("span", { class: "score" }, `score ${result.score.toFixed(4)}`), likeness(result)),
      result.model.size ? el("span", { class: "size" }, sizeLabel(result.model.size)) : null,
      buttons.length ? el("div", { class: "buttons" },
        buttons.map(([label, onclick]) => el("button", { type: "button", onclick: () => onclick(result) }, label))) : null);
  });
}

export { cards };

export async function modelPage(page, modelId) {
  // Ask for the preview at once, alongside the model (409 while not ready: ignored then).
  getPreview(modelId).catch(() => {});
  const model = await getJson(`/v1/models/${modelId}`);
  const main = el("div", {});
  const highlight = { show: null }; // set once the view exists (a ready assembly)
  const side = el("div", { class: "panel" }, el("h2", {}, "Facts"), facts(model), el("h2", {}, "Timings"), timings(model),
    assemblyPanel(model.id, (part) => highlight.show?.(part)));
  page.replaceChildren(el("h1", {}, modelLabel(model)), el("div", { class: "columns" }, main, side));
  if (model.status !== "ready") {
    main.append(el("p", { class: "hint" },
      model.status === "failed" ? `Failed: ${model.error?.detail}` : "Not described yet: this page shows the shape once it is ready (reload)."));
    return;
  }

  const preview = await getPreview(model.id);
  const views = el("div", { class: "views" });
  const query = viewBox(preview, "this model");
  views.append(query.box);
  const slider = el("input", { type: "range", min: "0", max: String(preview.times.length - 1), step: "1", id: "time-slider" });
  slider.value = String(Math.floor(preview.times.length / 2));
  const timeLabel = el("span", { id: "time-label" });
  const eigenPlot = el("canvas", { class: "plot", id: "eigenvalue-plot" });
  const similar = el("div", { class: "grid", id: "similar" }, el("span", { class: "hint" }, "searching..."));
  main.append(
    views,
    el("label", { class: "slider" }, "HKS time t", slider, timeLabel),
    el("p", { class: "hint" }, `${preview.n} of ${model.n_points} points; colour: log scaled heat kernel signature (heat that stays at a point after time t), low to high.`),
    el("h2", {}, "Most similar"), similar,
    el("h2", {}, `Eigenvalues (first ${preview.eigenvalues.length}; unit surface area)`), eigenPlot,
  );

  const views3d = [];
  const primary = new PointView(query.canvas);
  primary.setCloud(preview.points, scaledColumn(preview, +slider.value));
  views3d.push([primary, preview]);
  let highlighted = null; // the assembly's labelled points while a part is highlighted
  const setTime = () => {
    const index = +slider.value;
    timeLabel.textContent = preview.times[index].toExponential(2);
    if (highlighted) { // back to the HKS colours of the preview
      highlighted = null;
      query.box.firstChild.textContent = "this model";
      delete query.canvas.dataset.highlighted;
      primary.setCloud(preview.points, scaledColumn(preview, index));
    }
    for (const [view, shown] of views3d) view.setValues(scaledColumn(shown, index));
  };
  highlight.show = async (part) => {
    highlighted ??= await labelledCloud(model.id);
    const values = highlighted.values(part.id);
    primary.setCloud(highlighted.points, values);
    query.box.firstChild.textContent = `${modelLabel(part)} highlighted (the slider goes back to the heat colours)`;
    query.canvas.dataset.highlighted = part.id;
    query.canvas.dataset.highlightedPoints = String(values.filter((v) => v > 0).length);
  };
  slider.addEventListener("input", setTime);
  setTime();

  plotXY(eigenPlot, [{ points: Array.from(preview.eigenvalues, (v, i) => [i + 1, v]), line: true }],
    { xLabel: "index i", yLabel: "eigenvalue" });

  let other = null;
  async function compare(result) {
    const shown = await getPreview(result.model.id);
    if (!other) {
      other = viewBox(shown, "");
      views.append(other.box);
      other.view = new PointView(other.canvas);
      views3d.push([other.view, shown]);
    }
    other.box.firstChild.replaceChildren(el("a", { href: `#/models/${result.model.id}` }, modelLabel(result.model)), ` (score ${result.score.toFixed(4)})`);
    views3d[1][1] = shown;
    other.view.setCloud(shown.points, scaledColumn(shown, +slider.value));
    primary.draw();
  }

  try {
    const answer = await getJson(`/v1/models/${model.id}/similar?k=${SIMILAR_K}`);
    const aligned = (result) => { location.hash = `#/models/${model.id}/compare/${result.model.id}`; };
    similar.replaceChildren(...(answer.results.length
      ? cards(answer.results, [["side by side", compare], ["compare", aligned]])
      : [el("span", { class: "hint" }, "No other ready model described under the same descriptor version yet: upload another part to compare.")]));
  } catch (error) {
    similar.replaceChildren(el("span", { class: "error" }, error instanceof ApiError ? error.message : String(error)));
  }
}
