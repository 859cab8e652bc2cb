// Why two parts match: both in one 3D frame, the second placed on the first and coloured by
// how far each of its points lies from the first (a legend in the first's units), the
// figures beside them, and a toggle to show one, the other or both. Reached from a model
// page's similar cards (#/models/{id}/compare/{other}: GET /v1/models/{id}/compare/{other})
// and from a scan search's explained answers (the scan placed on a part: POST /v1/search
// with explain=true).

import { el, getJson, modelLabel } from "./api.js";
import { PointView, colour } from "./pointview.js";

export const COMPARE_POINTS = 2000;

const fmt = (value, digits = 3) => Number(Number(value).toPrecision(digits)).toString();
const percent = (share) => `${(100 * share).toFixed(1)} %`;

// A round top for the colour scale: at least twice the tolerance, else the 95th percentile.
function scaleTop(deviations, tolerance) {
  const sorted = Float32Array.from(deviations).sort();
  const p95 = sorted.length ? sorted[Math.floor(0.95 * (sorted.length - 1))] : 0;
  const top = Math.max(2 * tolerance, p95, 1e-12);
  const step = 10 ** Math.floor(Math.log10(top));
  for (const nice of [1, 2, 2.5, 5, 10]) if (nice * step >= top) return nice * step;
  return top;
}

// Points of both parts, centred on the first's box, with a value per point: -1 (drawn
// grey) for the first, the deviation over the scale's top for the second.
function clouds(points, top) {
  const first = points.model.positions, second = points.other.positions;
  const low = [Infinity, Infinity, Infinity], high = [-Infinity, -Infinity, -Infinity];
  for (const p of first) for (let j = 0; j < 3; j++) {
    low[j] = Math.min(low[j], p[j]);
    high[j] = Math.max(high[j], p[j]);
  }
  const centre = low.map((v, j) => (v + high[j]) / 2);
  const flat = (rows) => {
    const out = new Float32Array(rows.length * 3);
    rows.forEach((p, i) => { for (let j = 0; j < 3; j++) out[3 * i + j] = p[j] - centre[j]; });
    return out;
  };
  return {
    model: { points: flat(first), values: new Float32Array(first.length).fill(-1) },
    other: {
      points: flat(second),
      values: Float32Array.from(points.other.deviations, (d) => Math.min(d / top, 1)),
    },
  };
}

function joined(parts) {
  const points = new Float32Array(parts.reduce((n, p) => n + p.points.length, 0));
  const values = new Float32Array(parts.reduce((n, p) => n + p.values.length, 0));
  let at = 0, atValue = 0;
  for (const part of parts) {
    points.set(part.points, at);
    values.set(part.values, atValue);
    at += part.points.length;
    atValue += part.values.length;
  }
  return { points, values };
}

function legend(top, tolerance, units, names) {
  const bar = el("canvas", { class: "legend-bar", width: "256", height: "14" });
  const context = bar.getContext("2d");
  for (let x = 0; x < 256; x++) {
    const [r, g, b] = colour(x / 255);
    context.fillStyle = `rgb(${r * 255 | 0},${g * 255 | 0},${b * 255 | 0})`;
    context.fillRect(x, 0, 1, 14);
  }
  const unit = units ? ` ${units}` : "";
  const mark = el("span", { class: "legend-tolerance", style: `left: ${(100 * tolerance) / top}%` });
  return el("div", { class: "legend", id: "compare-legend" },
    el("div", { class: "legend-title" }, el("span", { class: "legend-swatch" }), ` ${names[0]}; `,
      `${names[1]} coloured by its distance from it:`),
    el("div", { class: "legend-scale" }, bar, mark),
    el("div", { class: "legend-ticks" },
      el("span", { style: "left: 0" }, "0"),
      el("span", { style: `left: ${(100 * tolerance) / top}%; transform: translateX(-50%)` },
        `tolerance ${fmt(tolerance)}${unit}`),
      el("span", { style: "right: 0" }, `${fmt(top)}${unit}+`)));
}

// The figures: rows [name, value], and (for two parts) rows [name, first's, second's]
// under the headers ["", first, second].
function figures(rows, headers) {
  const head = headers ? el("thead", {}, el("tr", {}, headers.map((h) => el("th", {}, h)))) : null;
  return el("table", { class: "facts figures", id: "compare-figures" }, head,
    el("tbody", {}, rows.map(([name, ...values]) => el("tr", {}, el("th", {}, name),
      values.map((value) => el("td", { "data-figure": name, colspan: values.length === 1 && headers ? "2" : null }, value))))));
}

// The view itself: data = {names: [first, second], units, points: {model, other},
// tolerance, rows: [[name, value] or [name, first's, second's], ...], headers}.
export function compareView(data) {
  const canvas = el("canvas", { class: "view", id: "compare-canvas" });
  const top = scaleTop(data.points.other.deviations, data.tolerance);
  const parts = clouds(data.points, top);
  const choices = [["both", "both"], ["model", data.names[0]], ["other", data.names[1]]];
  const toggle = el("div", { class: "toggle", id: "compare-toggle", role: "radiogroup" });
  const box = el("div", { class: "compare" },
    el("div", { class: "viewbox" }, toggle, canvas, legend(top, data.tolerance, data.units, data.names)),
    el("div", { class: "panel" }, el("h2", {}, "Figures"), figures(data.rows, data.headers),
      data.note ? el("p", { class: "hint" }, data.note) : null));
  const view = new PointView(canvas);
  view.zoom = 1.4; // the parts' bounding sphere is loose around a long part
  const show = (which) => {
    for (const button of toggle.children) button.setAttribute("aria-pressed", String(button.dataset.show === which));
    const shown = which === "both" ? joined([parts.model, parts.other]) : parts[which];
    view.setCloud(shown.points, shown.values);
  };
  for (const [which, label] of choices) {
    toggle.append(el("button", { type: "button", "data-show": which, onclick: () => show(which) }, label));
  }
  // The frame is drawn once the box is in the page (its size is known then).
  requestAnimationFrame(() => show("both"));
  return box;
}

// The figures of GET /v1/models/{id}/compare/{other}: per part, its points' distances
// from the other part.
function compareRows(answer) {
  const u = answer.units ? ` ${answer.units}` : "";
  const a = answer.alignment;
  const there = answer.model_to_other, back = answer.other_to_model;
  const both = (key, show) => [show(there[key]), show(back[key])];
  const length = (v) => `${fmt(v)}${u}`;
  return [
    ["RMS", ...both("rms", length)],
    ["mean", ...both("mean", length)],
    ["95th percentile", ...both("p95", length)],
    ["maximum", ...both("max", length)],
    [`within ${fmt(answer.tolerance)}${u}`, ...both("within", percent)],
    ["size ratios", answer.size_ratios.map((r) => fmt(r)).join(" x ")],
    ...[["model", answer.model], ["other", answer.other]].map(([key, part]) =>
      [`extents of ${modelLabel(part)}`, answer.extents[key].map((v) => fmt(v)).join(" x ") + u]),
    ["scale", fmt(a.scale, 5)],
    ["starts tried", String(a.candidates)],
    ["points", `${answer.points_source.model} / ${answer.points_source.other}`],
  ];
}

export async function comparePage(page, modelId, otherId, scale = false) {
  page.replaceChildren(el("h1", {}, "Comparing..."));
  const query = new URLSearchParams({ points: String(COMPARE_POINTS), scale: String(scale) });
  const answer = await getJson(`/v1/models/${modelId}/compare/${otherId}?${query}`);
  const names = [modelLabel(answer.model), modelLabel(answer.other)];
  const scaled = el("label", { class: "hint" },
    el("input", { type: "checkbox", id: "compare-scale", checked: scale || null,
      onchange: (event) => comparePage(page, modelId, otherId, event.target.checked) }),
    " also scale the second part (another size, or other units)");
  page.replaceChildren(
    el("h1", {}, el("a", { href: `#/models/${answer.model.id}` }, names[0]), " and ",
      el("a", { href: `#/models/${answer.other.id}` }, names[1])),
    el("p", { class: "hint" }, `${names[1]} placed on ${names[0]} (lengths in ${answer.units || "the files' units"}).`),
    scaled,
    compareView({
      names, units: answer.units, points: answer.points, tolerance: answer.tolerance,
      rows: compareRows(answer), headers: ["", `${names[0]}'s points`, `${names[1]}'s points`],
      note: `Distances of each part's points from the other part's surface; size ratios: ${names[1]} over ${names[0]} along ${names[0]}'s principal axes.`,
    }),
  );
}

// The figures of an explained search answer (the scan placed on a part).
export function explanationView(result, scanName) {
  const e = result.explanation;
  const units = result.model.size?.units || null;
  const u = units ? ` ${units}` : "";
  const names = [modelLabel(result.model), scanName];
  const rows = [
    ["scan RMS from the part", `${fmt(e.rms)}${u}`],
    [`part covered within ${fmt(e.tolerance)}${u}`, percent(e.coverage)],
    ["scale of the scan", fmt(e.alignment.scale, 5)],
    ["view matched", e.view === null ? "the whole part" : `view ${e.view}`],
    ["starts tried", String(e.alignment.candidates)],
  ];
  return el("div", { id: "search-compare" },
    el("h2", {}, `${scanName} placed on `, el("a", { href: `#/models/${result.model.id}` }, names[0])),
    compareView({ names, units, points: e.points, tolerance: e.tolerance, rows }));
}
