// Assemblies on a model page (issue 76): an assembly's parts with their counts, and the
// assemblies a part is used in (itself or a copy of it), each a link to its page.

import { ApiError, el, getJson, modelLabel } from "./api.js";

function links(entries, label) {
  return el("ul", { class: "links" }, entries.map((entry) =>
    el("li", { "data-model-id": entry.model.id },
      el("a", { href: `#/models/${entry.model.id}` }, modelLabel(entry.model)), ` ${label(entry)}`)));
}

// A panel of the model's parts and where it is used; empty when it has neither.
export function assemblyPanel(modelId) {
  const panel = el("div", { id: "assembly" });
  Promise.all([
    getJson(`/v1/models/${modelId}/parts`),
    getJson(`/v1/models/${modelId}/where-used`),
  ]).then(([parts, used]) => {
    const children = [];
    if (parts.parts.length) {
      const placed = parts.parts.reduce((sum, part) => sum + part.count, 0);
      children.push(el("h2", {}, `Parts (${parts.parts.length} distinct, ${placed} placed)`),
        el("div", { id: "parts" }, links(parts.parts, (part) => `\u00d7 ${part.count}`)));
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
