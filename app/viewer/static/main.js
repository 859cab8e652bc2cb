// The viewer's router: #/ catalogue, #/models/{id}, #/models/{id}/compare/{other},
// #/search, #/database.

import { installKeyDialog, el } from "./api.js";
import { catalogue } from "./catalogue.js";
import { comparePage } from "./compare.js";
import { databasePage } from "./database.js";
import { modelPage } from "./model.js";
import { searchPage } from "./search.js";

let current = null;

async function route() {
  current?.abort();
  current = new AbortController();
  const page = document.getElementById("page");
  const hash = location.hash.replace(/^#/, "") || "/";
  const model = hash.match(/^\/models\/([0-9a-fA-F-]+)$/);
  const pair = hash.match(/^\/models\/([0-9a-fA-F-]+)\/compare\/([0-9a-fA-F-]+)$/);
  try {
    if (model) await modelPage(page, model[1]);
    else if (pair) await comparePage(page, pair[1], pair[2]);
    else if (hash === "/search") searchPage(page);
    else if (hash === "/database") databasePage(page, current.signal);
    else catalogue(page, current.signal);
  } catch (error) {
    page.replaceChildren(el("h1", {}, "Something went wrong"), el("p", { class: "error" }, error.message));
  }
}

installKeyDialog();
window.addEventListener("hashchange", route);
route();
