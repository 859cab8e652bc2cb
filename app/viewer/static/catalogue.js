// The catalogue: every model with its status (refreshed while the page is open), a text
// search over name and external id, a metadata filter, and drag-and-drop upload.

import { el, getJson, modelLabel, sizeLabel, statusBadge, uploadFile } from "./api.js";

const REFRESH_MS = 1500;

async function allModels() {
  const items = [];
  let cursor = null;
  do {
    const query = new URLSearchParams({ limit: "500" });
    if (cursor) query.set("cursor", cursor);
    const page = await getJson(`/v1/models?${query}`);
    items.push(...page.items);
    cursor = page.next_cursor;
  } while (cursor && items.length < 5000);
  return items;
}

// "material=steel, grade=2": every pair must match (values compare as text).
function metadataMatches(model, filter) {
  return filter
    .split(",")
    .map((pair) => pair.split("=").map((part) => part.trim()))
    .filter(([key]) => key)
    .every(([key, value]) => key in model.metadata && (value === undefined || String(model.metadata[key]) === value));
}

function row(model) {
  const cutoff = model.cutoff;
  return el("tr", { "data-model-id": model.id },
    el("td", {}, el("a", { href: `#/models/${model.id}` }, modelLabel(model))),
    el("td", {}, model.external_id || ""),
    el("td", {}, statusBadge(model.status), model.error ? el("div", { class: "error" }, model.error.detail) : null),
    el("td", {}, model.n_points ?? ""),
    el("td", { "data-size": "" }, sizeLabel(model.size)),
    el("td", {}, cutoff ? cutoff.n : ""),
    el("td", {}, Object.entries(model.metadata).map(([k, v]) => `${k}=${typeof v === "string" ? v : JSON.stringify(v)}`).join(", ")),
    el("td", {}, new Date(model.created_at).toLocaleString()),
  );
}

function uploadPanel(onUploaded) {
  const list = el("ul", { class: "uploads", id: "upload-list" });
  const input = el("input", { type: "file", multiple: true, id: "file-input" });

  function send(file) {
    const progress = el("progress", { max: "1", value: "0" });
    const outcome = el("span", { class: "outcome" }, "uploading");
    list.append(el("li", { "data-file": file.name }, el("span", {}, file.name), progress, outcome));
    const form = new FormData();
    form.append("file", file, file.name);
    form.append("name", file.name); // similar results carry the name, not the file
    uploadFile("/v1/models", form, (fraction) => { progress.value = fraction; })
      .then((model) => {
        progress.value = 1;
        outcome.replaceChildren(el("a", { href: `#/models/${model.id}` }, "accepted"), " ", statusBadge(model.status));
        onUploaded();
      })
      .catch((error) => {
        outcome.className = "outcome error";
        outcome.textContent = `${error.status || ""} ${error.message}`.trim();
      });
  }

  const sendAll = (files) => [...files].forEach(send);
  input.addEventListener("change", () => { sendAll(input.files); input.value = ""; });
  const drop = el("div", { class: "drop", id: "drop-zone" },
    "Drop meshes, point clouds or scans here (stl, obj, ply, glb, step, xyz, pcd, e57, las, "
    + "laz, ...) or ", input);
  drop.addEventListener("dragover", (event) => { event.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (event) => {
    event.preventDefault();
    drop.classList.remove("over");
    sendAll(event.dataTransfer.files);
  });
  return [drop, list];
}

export function catalogue(page, signal) {
  const text = el("input", { type: "search", placeholder: "name, external id or file", id: "text-filter" });
  const meta = el("input", { type: "search", placeholder: "metadata: material=steel", id: "metadata-filter" });
  const body = el("tbody", { id: "models" });
  const count = el("span", { class: "hint" });
  let models = [];

  function render() {
    const needle = text.value.trim().toLowerCase();
    const shown = models.filter((m) =>
      (!needle || `${m.name || ""} ${m.external_id || ""} ${m.file.filename}`.toLowerCase().includes(needle)) &&
      metadataMatches(m, meta.value));
    body.replaceChildren(...shown.map(row));
    count.textContent = `${shown.length} of ${models.length} models`;
  }

  async function refresh() {
    try {
      models = await allModels();
      render();
    } catch (error) {
      count.textContent = error.message;
    }
  }

  text.addEventListener("input", render);
  meta.addEventListener("input", render);
  page.replaceChildren(
    el("h1", {}, "Catalogue"),
    ...uploadPanel(refresh),
    el("div", { class: "toolbar" }, text, meta, count),
    el("table", {},
      el("thead", {}, el("tr", {}, ["name", "external id", "status", "points", "size (L x W x H)", "n", "metadata", "created"].map((h) => el("th", {}, h)))),
      body),
  );
  refresh();
  const timer = setInterval(refresh, REFRESH_MS);
  signal.addEventListener("abort", () => clearInterval(timer));
}
