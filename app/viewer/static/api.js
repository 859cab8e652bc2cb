// The /v1 API as the viewer uses it: the key in an Authorization header (never in a URL),
// problem+json errors as exceptions with their detail, and the preview blob decoded.

const KEY_STORAGE = "shapesearch.key";

export class ApiError extends Error {
  constructor(status, problem) {
    super(problem.detail || problem.title || `HTTP ${status}`);
    this.status = status;
    this.problem = problem;
  }
}

export function apiKey() {
  return sessionStorage.getItem(KEY_STORAGE);
}

export function setApiKey(key) {
  sessionStorage.setItem(KEY_STORAGE, key);
}

export function authHeaders() {
  const key = apiKey();
  return key ? { Authorization: `Bearer ${key}` } : {};
}

let keyWaiters = [];

// Ask for a key once, however many requests are waiting for it.
function askForKey() {
  const dialog = document.getElementById("key-dialog");
  const promise = new Promise((resolve) => keyWaiters.push(resolve));
  if (!dialog.open) dialog.showModal();
  return promise;
}

export function installKeyDialog() {
  const form = document.getElementById("key-form");
  const input = document.getElementById("key-input");
  const button = document.getElementById("key-button");
  form.addEventListener("submit", () => {
    setApiKey(input.value.trim());
    input.value = "";
    button.hidden = false;
    const waiters = keyWaiters;
    keyWaiters = [];
    waiters.forEach((resolve) => resolve());
  });
  button.hidden = !apiKey();
  button.addEventListener("click", () => askForKey().then(() => window.dispatchEvent(new HashChangeEvent("hashchange"))));
}

async function problemOf(response) {
  try {
    return await response.json();
  } catch {
    return { title: response.statusText };
  }
}

// fetch with the key; on 401 ask for a key and try again.
export async function request(path, options = {}) {
  for (;;) {
    const response = await fetch(path, {
      ...options,
      headers: { ...(options.headers || {}), ...authHeaders() },
    });
    if (response.status === 401) {
      await askForKey();
      continue;
    }
    if (!response.ok) throw new ApiError(response.status, await problemOf(response));
    return response;
  }
}

export async function getJson(path) {
  return (await request(path)).json();
}

// Upload with progress (fetch has no upload progress): onProgress(fraction).
export function uploadFile(path, form, onProgress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open("POST", path);
    for (const [name, value] of Object.entries(authHeaders())) xhr.setRequestHeader(name, value);
    xhr.upload.onprogress = (event) => {
      if (event.lengthComputable) onProgress(event.loaded / event.total);
    };
    xhr.onload = () => {
      let body = {};
      try { body = JSON.parse(xhr.responseText); } catch { body = { title: xhr.statusText }; }
      if (xhr.status >= 200 && xhr.status < 300) resolve(body);
      else reject(new ApiError(xhr.status, body));
    };
    xhr.onerror = () => reject(new ApiError(0, { detail: "network error" }));
    xhr.send(form);
  });
}

// float16 -> float32 for a Uint16Array.
function halfToFloat(halves) {
  const out = new Float32Array(halves.length);
  for (let i = 0; i < halves.length; i++) {
    const h = halves[i];
    const sign = h & 0x8000 ? -1 : 1;
    const exponent = (h >> 10) & 0x1f;
    const fraction = h & 0x3ff;
    if (exponent === 0) out[i] = sign * 2 ** -14 * (fraction / 1024);
    else if (exponent === 31) out[i] = fraction ? NaN : sign * Infinity;
    else out[i] = sign * 2 ** (exponent - 15) * (1 + fraction / 1024);
  }
  return out;
}

// The blob of app/ingest/previews.py: {n, times, eigenvalues, points (n*3), logHks (n*s)}.
export function decodePreview(buffer) {
  const view = new DataView(buffer);
  const magic = String.fromCharCode(...new Uint8Array(buffer, 0, 4));
  if (magic !== "SSP1") throw new Error("not a preview");
  const n = view.getUint32(4, true), s = view.getUint32(8, true), k = view.getUint32(12, true);
  let offset = 16;
  const floats = (count) => {
    const out = new Float32Array(count);
    for (let i = 0; i < count; i++) out[i] = view.getFloat32(offset + 4 * i, true);
    offset += 4 * count;
    return out;
  };
  const halves = (count) => {
    const out = halfToFloat(new Uint16Array(buffer.slice(offset, offset + 2 * count)));
    offset += 2 * count;
    return out;
  };
  const times = floats(s);
  const eigenvalues = floats(k);
  const points = halves(3 * n);
  const logHks = halves(n * s);
  return { n, times, eigenvalues, points, logHks };
}

const previews = new Map();

export function getPreview(modelId) {
  if (!previews.has(modelId)) {
    const promise = request(`/v1/models/${modelId}/preview`)
      .then((response) => response.arrayBuffer())
      .then(decodePreview);
    promise.catch(() => previews.delete(modelId));
    previews.set(modelId, promise);
  }
  return previews.get(modelId);
}

// el("a", {href: "#/"}, "text", child): DOM without innerHTML, so names are never markup.
export function el(tag, attributes = {}, ...children) {
  const node = document.createElement(tag);
  for (const [name, value] of Object.entries(attributes)) {
    if (name === "class") node.className = value;
    else if (name.startsWith("on")) node.addEventListener(name.slice(2), value);
    else if (value !== undefined && value !== null && value !== false) node.setAttribute(name, value);
  }
  for (const child of children.flat()) {
    if (child === null || child === undefined || child === false) continue;
    node.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return node;
}

export function statusBadge(status) {
  return el("span", { class: `status ${status}`, "data-status": status }, status);
}

// "34.3 x 34 x 25.4 mm": a model's size, or "" without one.
export function sizeLabel(size) {
  if (!size) return "";
  const fmt = (v) => Number(v.toPrecision(3)).toString();
  return `${fmt(size.length)} x ${fmt(size.width)} x ${fmt(size.height)}${size.units ? " " + size.units : ""}`;
}

export function modelLabel(model) {
  return model.name || model.external_id || model.file?.filename || model.id.slice(0, 8);
}
