// Search by scan: drop a file, see the top-k stored models with previews (POST /v1/search),
// the first few explained: the scan placed on the part, shown on demand (compare.js).

import { el, uploadFile } from "./api.js";
import { COMPARE_POINTS, explanationView } from "./compare.js";
import { cards } from "./model.js";

const K = 8;

export function searchPage(page) {
  const input = el("input", { type: "file", id: "search-input" });
  const outcome = el("div", { id: "search-outcome", class: "hint" });
  const results = el("div", { class: "grid", id: "search-results" });
  const placed = el("div", {});
  const drop = el("div", { class: "drop", id: "search-drop" }, "Drop a scan or a mesh here, or ", input,
    el("div", {}, "Nothing is stored: the file is described and compared with the database."));

  function search(file) {
    const form = new FormData();
    form.append("file", file, file.name);
    outcome.textContent = `describing ${file.name}...`;
    results.replaceChildren();
    placed.replaceChildren();
    uploadFile(`/v1/search?k=${K}&explain=true&points=${COMPARE_POINTS}`, form, () => {})
      .then((answer) => {
        outcome.textContent = `${file.name}: ${answer.query.n_points} points, cutoff n = ${answer.query.cutoff.n}; ${answer.results.length} results`;
        const show = (result) => {
          placed.replaceChildren(explanationView(result, file.name));
          placed.scrollIntoView({ behavior: "smooth" });
        };
        results.replaceChildren(...answer.results.map((result) =>
          cards([result], result.explanation ? [["compare", show]] : [])[0]));
      })
      .catch((error) => {
        outcome.className = "error";
        outcome.textContent = `${error.status || ""} ${error.message}`.trim();
      });
  }

  input.addEventListener("change", () => input.files[0] && search(input.files[0]));
  drop.addEventListener("dragover", (event) => { event.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (event) => {
    event.preventDefault();
    drop.classList.remove("over");
    if (event.dataTransfer.files[0]) search(event.dataTransfer.files[0]);
  });
  page.replaceChildren(el("h1", {}, "Search by scan"), drop, outcome, results, placed);
}
