// Assemblies on a model page (issue 76): an assembly's parts with their counts, a preview of
// each and a button that highlights the part in the assembly's view; and the assemblies a
// part is used in (itself or a copy of it), each a link to its page.

import { ApiError, el, getJson, getPreview, modelLabel } from "./api.js";
import { drawThumbnail } from "./pointview.js";

function links(entries, label, extra = () => null) {
  return el("ul", { class: "links" }, entries.map((entry) =>
    el("li", { "data-model-id": entry.model.id }, extra(entry),
      el("a", { href: `#/models/${entry.model.id}` }, modelLabel(entry.model)), ` ${label(entry)}`)));
}

// A small drawing of a part's preview (none while the part is not described).
function thumbnail(modelId) {
  const canvas = el("canvas", { class: "thumb", width: "48", height: "48" });
  getPreview(modelId)
    .then((preview) => drawThumbnail(canvas, preview, Math.floor(preview.times.length / 2)))
    .catch(() => canvas.classList.add("empty"));
  return canvas;
}

// A panel of the model's parts and where it is used; empty when it has neither. onShow(part
// model) highlights a part in the assembly's view (the model page sets it up).
export function assemblyPanel(modelId, onShow = null) {
  const panel = el("div", { id: "assembly" });
  Promise.all([
    getJson(`/v1/models/${modelId}/parts`),
    getJson(`/v1/models/${modelId}/where-used`),
  ]).then(([parts, used]) => {
    const children = [];
    if (parts.parts.length) {
      const placed = parts.parts.reduce((sum, part) => sum + part.count, 0);
      const extra = (part) => [thumbnail(part.model.id), onShow ? el("button", {
        type: "button", class: "show", title: "highlight this part in the assembly's view",
        onclick: () => onShow(part.model),
      }, "show") : null];
      children.push(el("h2", {}, `Parts (${parts.parts.length} distinct, ${placed} placed)`),
        el("div", { id: "parts" }, links(parts.parts, (part) => `\u00d7 ${part.count}`, extra)));
    }
    if (used.assemblies.length) {
      const entries = used.assemblies.map((entry) => ({ ...entry, model: entry.assembly }));
      children.push(el("h2", {}, "Used in"),
        el("div", { id: "used-in" }, links(entries, (entry) =>
          `\u00d7 ${entry.count}${entry.parts.includes(modelId) ? "" : " (as a copy)"}`)));
    }
    panel.replaceChildren(...children);
  }).catch((error) => {
    panel.replaceChildren(el("span", { class: "error" }, error instanceof ApiError ? error.message : String(error)));
  });
  return panel;
}

// Points on an assembly labelled with their parts, centred for a PointView; values(part)
// colours that part's points (1) and greys the others (-1).
export async function labelledCloud(assemblyId) {
  const answer = await getJson(`/v1/models/${assemblyId}/parts/points`);
  const n = answer.points.length;
  const low = [Infinity, Infinity, Infinity], high = [-Infinity, -Infinity, -Infinity];
  for (const point of answer.points) {
    for (let j = 0; j < 3; j++) { low[j] = Math.min(low[j], point[j]); high[j] = Math.max(high[j], point[j]); }
  }
  const points = new Float32Array(3 * n);
  answer.points.forEach((point, i) => {
    for (let j = 0; j < 3; j++) points[3 * i + j] = point[j] - (low[j] + high[j]) / 2;
  });
  const values = (partId) => {
    const index = answer.part_ids.indexOf(partId);
    return Float32Array.from(answer.labels, (label) => (label === index ? 1 : -1));
  };
  return { points, values };
}
