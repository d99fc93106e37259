// brdffit's page: plain JavaScript over the service's JSON routes, nothing else.
"use strict";

const $ = (sel) => document.querySelector(sel);
const AXES = ["origin", "symmetry", "operand", "highlight"];
const DEFAULT_MODELS = ["ward", "ggx", "blinn"];
const TERMINAL = new Set(["done", "failed", "interrupted", "cancelled", "deleted"]);
const TOKEN_KEY = "brdffit-token";
const POLL_MS = 700;
const state = { models: [], targets: {}, file: null, jobs: {}, comparison: null, timer: null };

function el(tag, attrs = {}, ...children) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === null || v === undefined || v === false) continue;
    if (k === "text") node.textContent = v;
    else node.setAttribute(k, v === true ? "" : v);
  }
  for (const child of children) node.append(child);
  return node;
}

function fmt(x, digits = 4) {
  if (x === null || x === undefined) return "–";
  if (typeof x !== "number") return String(x);
  if (x !== 0 && (Math.abs(x) < 1e-3 || Math.abs(x) >= 1e5)) return x.toExponential(digits - 1);
  return Number(x.toPrecision(digits)).toString();
}

// ------------------------------------------------------------------- token
// A server that listens beyond its own machine asks for its API token
// (BRDFFIT_API_TOKEN): the page asks the user for it once, keeps it in this
// tab (sessionStorage) and sends it as a bearer token on every API call.
function apiToken() {
  try { return sessionStorage.getItem(TOKEN_KEY) || ""; } catch (e) { return ""; }
}

function askToken(why) {
  $("#token-box").hidden = false;
  $("#token-error").hidden = !why;
  $("#token-error").textContent = why || "";
  $("#token").focus();
}

async function apiFetch(url, options = {}) {
  const headers = new Headers(options.headers || {});
  const token = apiToken();
  if (token) headers.set("Authorization", `Bearer ${token}`);
  const response = await fetch(url, { ...options, headers });
  if (response.status === 401) askToken(token ? "The service refused this token; enter it again." : "");
  return response;
}

function wireToken() {
  $("#token-form").addEventListener("submit", (e) => {
    e.preventDefault();
    try { sessionStorage.setItem(TOKEN_KEY, $("#token").value.trim()); } catch (err) { /* private mode */ }
    window.location.reload();
  });
}

async function getJSON(url, options) {
  const response = await apiFetch(url, options);
  let body = null;
  try { body = await response.json(); } catch (e) { body = null; }
  if (!response.ok) {
    const error = new Error((body && body.message) || `${url} answered ${response.status}`);
    error.body = body || { field: null, message: error.message };
    error.status = response.status;
    throw error;
  }
  return body;
}

// ------------------------------------------------------------------ errors
const ERROR_PLACES = [
  [/^(file|format|body|data|test_fraction)/, "#file-error", "#file"],
  [/^models?$/, "#models-error", "#models-extra"],
  [/^(options\.)?loss$/, "#loss-error", "#loss"],
  [/^(options\.)?(timeout|max_evals|posterior_options.*)$/, "#options-error", "#timeout"],
  [/^(options\.)?seed$/, "#options-error", "#seed"],
  [/^options|^(energy_conserving|uncertainty|fixed|free|start|weights)/, "#options-error", null],
];

function clearErrors() {
  for (const p of document.querySelectorAll("#fit-form .error")) { p.hidden = true; p.textContent = ""; }
  for (const i of document.querySelectorAll("[aria-invalid]")) i.removeAttribute("aria-invalid");
}

function showError(body) {
  const items = (body.errors && body.errors.length) ? body.errors : [body];
  let first = null;
  for (const item of items) {
    const field = item.field || "";
    const place = ERROR_PLACES.find(([re]) => re.test(field));
    const where = $(place ? place[1] : "#form-error");
    const input = place && place[2] ? $(place[2]) : null;
    const text = field ? `${field}: ${item.message}` : item.message;
    where.textContent = where.hidden ? text : `${where.textContent} ${text}`;
    where.hidden = false;
    if (input) input.setAttribute("aria-invalid", "true");
    first = first || input || where;
  }
  if (first && first.focus) first.focus();
}

// ------------------------------------------------------------------ models
function modelMatches(model) {
  return AXES.every((axis) => {
    const want = $(`#f-${axis}`).value;
    return !want || String(model.classification[axis]) === want;
  });
}

function renderModelList() {
  const list = $("#model-list");
  for (const div of list.children) {
    const model = state.models.find((m) => m.name === div.dataset.model);
    div.hidden = !modelMatches(model);
  }
  updateCount();
}

function chosenModels() {
  const ticked = [...document.querySelectorAll("#model-list input:checked")].map((i) => i.value);
  const extra = $("#models-extra").value.split(",").map((s) => s.trim()).filter(Boolean);
  return [...new Set([...ticked, ...extra])];
}

function updateCount() {
  const shown = [...$("#model-list").children].filter((d) => !d.hidden).length;
  const n = chosenModels().length;
  $("#models-count").textContent = `${n} model${n === 1 ? "" : "s"} chosen; ${shown} of ${state.models.length} shown.`;
}

async function loadModels() {
  state.models = await getJSON("/models");
  const list = $("#model-list");
  for (const axis of AXES) {
    const values = [...new Set(state.models.map((m) => String(m.classification[axis])))].sort();
    for (const v of values) $(`#f-${axis}`).append(el("option", { value: v, text: v }));
  }
  for (const model of state.models) {
    const id = `m-${model.name}`;
    const c = model.classification;
    const about = `${c.origin}, ${c.symmetry}, ${c.operand}, ${c.highlight}`;
    list.append(el("div", { "data-model": model.name },
      el("input", { type: "checkbox", id, value: model.name, checked: DEFAULT_MODELS.includes(model.name) }),
      " ", el("label", { for: id, title: model.doc }, model.name, " ", el("span", { class: "hint", text: `(${about})` }))));
  }
  renderModelList();
}

async function loadLosses() {
  const api = await getJSON("/openapi.json");
  const loss = api.components.schemas.FitIn.properties.loss;
  const names = (loss.anyOf || [loss]).flatMap((s) => s.enum || []);
  const select = $("#loss");
  select.append(el("option", { value: "", text: "default (chi2 with sigma, else l2)" }));
  for (const name of names) select.append(el("option", { value: name, text: name }));
}

async function loadTargets() {
  state.targets = await getJSON("/export/targets");
}

async function loadExamples() {
  const examples = await getJSON("/examples");
  if (!examples.length) return;
  for (const ex of examples) {
    const text = ex.model ? `${ex.name} (made by ${ex.model}, ${ex.n} samples)` : ex.name;
    $("#example").append(el("option", { value: ex.name, text }));
  }
  $("#example-row").hidden = false;
}

// -------------------------------------------------------------------- data
function chooseFile(file) {
  state.file = file;
  $("#chosen").textContent = file ? `Chosen: ${file.name} (${file.size} bytes)` : "";
  if (file) $("#example").value = "";
}

function wireDrop() {
  const drop = $("#drop");
  drop.addEventListener("dragover", (e) => { e.preventDefault(); drop.classList.add("over"); });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  drop.addEventListener("drop", (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    if (e.dataTransfer.files.length) chooseFile(e.dataTransfer.files[0]);
  });
  $("#file").addEventListener("change", (e) => chooseFile(e.target.files[0] || null));
  $("#example").addEventListener("change", (e) => {
    if (e.target.value) { state.file = null; $("#file").value = ""; $("#chosen").textContent = `Chosen: the example ${e.target.value}`; }
  });
}

async function dataFile() {
  const example = $("#example").value;
  if (example) {
    const response = await apiFetch(`/examples/${encodeURIComponent(example)}`);
    return new File([await response.blob()], example, { type: "text/csv" });
  }
  return state.file;
}

function fitOptions() {
  const options = { seed: Number($("#seed").value || 0),
                    energy_conserving: $("#energy").checked, uncertainty: $("#uncertainty").checked };
  if ($("#loss").value) options.loss = $("#loss").value;
  const seconds = Number($("#timeout").value);
  if (seconds) options.timeout = seconds;
  if (options.uncertainty) {
    const post = {};
    if (seconds) post.max_seconds = seconds;
    if ($("#steps").value) post.steps = Number($("#steps").value);
    options.posterior_options = post;
  }
  return options;
}

async function submit(event) {
  event.preventDefault();
  clearErrors();
  const file = await dataFile();
  if (!file) return showError({ field: "file", message: "choose a measurement file, drop one here, or pick an example" });
  const models = chosenModels();
  if (!models.length) return showError({ field: "models", message: "tick at least one model, or name one" });
  const form = new FormData();
  form.append("file", file, file.name);
  form.append("models", models.join(","));
  form.append("options", JSON.stringify(fitOptions()));
  form.append("test_fraction", $("#fraction").value || "0.2");
  const button = $("#submit");
  button.disabled = true;
  button.textContent = "Sending…";
  try {
    const comparison = await getJSON("/comparisons/file", { method: "POST", body: form });
    location.hash = `comparison=${comparison.id}`;  // the hash handler follows it
  } catch (error) {
    showError(error.body);
  } finally {
    button.disabled = false;
    button.textContent = "Fit and compare";
  }
}

// ---------------------------------------------------------------- progress
function follow() {
  clearTimeout(state.timer);
  const params = new URLSearchParams(location.hash.slice(1));
  state.jobs = {};
  state.comparison = null;
  $("#results").hidden = true;
  $("#model-results").replaceChildren();
  if (params.get("comparison")) followComparison(params.get("comparison"));
  else if (params.get("job")) followJobs([params.get("job")], null);
  else $("#progress").hidden = true;
}

async function followComparison(id) {
  try {
    const comparison = await getJSON(`/comparisons/${id}`);
    followJobs(comparison.entries.map((e) => e.job), id);
  } catch (error) {
    $("#progress").hidden = false;
    $("#progress-summary").textContent = error.message;
  }
}

async function followJobs(ids, comparisonId) {
  $("#progress").hidden = false;
  $("#progress").scrollIntoView({ block: "start" });
  const poll = async () => {
    await Promise.all(ids.filter((id) => !TERMINAL.has((state.jobs[id] || {}).status)).map(async (id) => {
      try { state.jobs[id] = await getJSON(`/jobs/${id}`); }
      catch (error) { state.jobs[id] = { id, status: "deleted", model: "?", error: error.body }; }
    }));
    renderProgress(ids);
    if (ids.every((id) => TERMINAL.has(state.jobs[id].status))) {
      const comparison = comparisonId ? await getJSON(`/comparisons/${comparisonId}`) : null;
      renderResults(ids, comparison);
    } else {
      state.timer = setTimeout(poll, POLL_MS);
    }
  };
  await poll();
}

function renderProgress(ids) {
  const rows = ids.map((id) => {
    const job = state.jobs[id];
    const p = job.progress || {};
    const stage = p.stage === "posterior" && p.steps ? `posterior, step ${p.steps}${p.max_steps ? ` of ${p.max_steps}` : ""}` : (p.stage || "–");
    return el("tr", { "data-job": id },
      el("th", { scope: "row", text: job.model }),
      el("td", { class: `status-${job.status}`, text: job.status }),
      el("td", { text: job.status === "done" ? "finished" : stage }),
      el("td", { class: "num", text: fmt(p.n_evals) }),
      el("td", { class: "num", text: fmt(p.best_loss) }),
      el("td", { class: "num", text: fmt(p.seconds, 3) }));
  });
  $("#progress-table tbody").replaceChildren(...rows);
  const finished = ids.filter((id) => TERMINAL.has(state.jobs[id].status)).length;
  $("#progress-summary").textContent = `${finished} of ${ids.length} job${ids.length === 1 ? "" : "s"} finished.`;
}

// ----------------------------------------------------------------- results
function renderResults(ids, comparison) {
  $("#results").hidden = false;
  const entries = comparison ? comparison.entries : ids.map((id) => {
    const r = state.jobs[id].result;
    return { model: state.jobs[id].model, job: id, status: state.jobs[id].status,
             bic: r ? r.metrics.bic : null, rank_bic: r ? 1 : null, rank_heldout: null, heldout_rmse: null };
  });
  const order = [...entries].sort((a, b) => (a.rank_heldout ?? 99) - (b.rank_heldout ?? 99) || (a.rank_bic ?? 99) - (b.rank_bic ?? 99));
  $("#ranking tbody").replaceChildren(...order.map((e) => el("tr", { "data-model": e.model, class: e.rank_heldout === 1 ? "best" : null },
    el("th", { scope: "row" }, el("a", { href: `#result-${e.job}`, text: e.model })),
    el("td", { class: "num rank-heldout", text: fmt(e.rank_heldout) }),
    el("td", { class: "num", text: fmt(e.heldout_rmse) }),
    el("td", { class: "num rank-bic", text: fmt(e.rank_bic) }),
    el("td", { class: "num", text: fmt(e.bic, 6) }),
    el("td", { class: `status-${e.status}`, text: e.status }))));
  $("#results-about").textContent = comparison
    ? `${comparison.source}: every model fitted to the same ${comparison.n_train} samples; ${comparison.n_test} held out (seed ${comparison.seed}).`
    : "One job: no held-out samples to rank by.";
  renderNotes(ids);
  const links = comparison ? [el("a", { href: `/comparisons/${comparison.id}`, download: `comparison-${comparison.id}.json`, text: "Download the comparison (JSON)" })] : [];
  $("#downloads-all").replaceChildren(...links);
  $("#model-results").replaceChildren(...order.map((e) => renderModel(state.jobs[e.job])));
  refreshRecent();
}

function renderNotes(ids) {
  const notes = [...new Set(ids.flatMap((id) => state.jobs[id].data_notes || []))];
  const box = $("#notes");
  box.replaceChildren();
  if (!notes.length) { box.append(el("p", { text: "Notes about the data: none (no negative values, no pairs dropped)." })); return; }
  box.append(el("h3", { text: "Notes about the data" }), el("ul", {}, ...notes.map((n) => el("li", { text: n }))));
}

function paramRows(result) {
  const summary = (result.posterior && result.posterior.summary) || {};
  const rows = [];
  for (const [name, value] of Object.entries(result.params)) {
    const values = Array.isArray(value) ? value : [value];
    values.forEach((v, i) => {
      const key = Array.isArray(value) ? `${name}[${result.channels[i]}]` : name;
      const s = summary[key];
      const fixed = name in (result.fixed || {});
      rows.push(el("tr", { "data-param": key },
        el("th", { scope: "row", text: key }),
        el("td", { class: "num value", "data-value": v, text: fmt(v, 5) }),
        el("td", { class: "num median", "data-value": s ? s.median : null, text: s ? fmt(s.median, 5) : (fixed ? "fixed" : "–") }),
        el("td", { class: "num interval", "data-p16": s ? s.p16 : null, "data-p84": s ? s.p84 : null,
                   text: s ? `−${fmt(s.median - s.p16, 2)} / +${fmt(s.p84 - s.median, 2)}` : "–" })));
    });
  }
  return rows;
}

function figure(src, alt, caption) {
  // With a token, an <img src> cannot send it: the picture is fetched, then shown.
  const token = apiToken();
  const img = el("img", { src: token ? null : src, alt, loading: "eager" });
  const link = el("a", { href: token ? null : src }, img);
  const note = el("figcaption", { text: caption });
  const noPicture = async (response) => {  // say why, from the service's JSON
    let why = "the picture could not be loaded";
    try { why = (await (response || await apiFetch(src)).json()).message || why; } catch (e) { /* keep */ }
    link.replaceWith(el("p", { class: "hint", text: `No picture: ${why}.` }));
  };
  img.addEventListener("error", () => noPicture(null));
  if (token) {
    apiFetch(src).then(async (response) => {
      if (!response.ok) return noPicture(response);
      const url = URL.createObjectURL(await response.blob());
      img.src = url;
      link.href = url;
    }).catch(() => noPicture(null));
  }
  return el("figure", {}, link, note);
}

// Save a blob as the file `name`, as a download link would.
function save(blob, name) {
  const url = URL.createObjectURL(blob);
  const link = el("a", { href: url, download: name, hidden: true });
  document.body.append(link);
  link.click();
  link.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}

// A download link; with a token, which a plain link cannot send, the file is fetched
// with it, then saved.
function downloadLink(href, name, text) {
  const link = el("a", { href, download: name, text });
  link.addEventListener("click", async (event) => {
    if (!apiToken()) return;
    event.preventDefault();
    const response = await apiFetch(href);
    if (response.ok) save(await response.blob(), name);
  });
  return link;
}

function renderModel(job) {
  const article = el("article", { id: `result-${job.id}`, "data-model": job.model, "aria-labelledby": `h-${job.id}` });
  article.append(el("h3", { id: `h-${job.id}`, text: `${job.model} (${job.status})` }));
  if (!job.result) {
    const error = job.error || {};
    article.append(el("p", { class: "error", text: error.message || "no result" }));
    return article;
  }
  const r = job.result;
  const post = r.posterior;
  article.append(el("p", { text: `${r.loss_name} loss ${fmt(r.loss)}, RMSE ${fmt(r.metrics.rmse)}, ${r.n_evals} evaluations in ${fmt(r.seconds, 3)} s; ${r.message}.` + (post ? ` Posterior: ${post.message}.` : "") }));
  article.append(el("div", { class: "scroll" }, el("table", { class: "params" },
    el("caption", { text: post ? "Parameters: the fit, and the posterior median with its 16–84 % interval" : "Parameters of the fit (uncertainty was not asked for)" }),
    el("thead", {}, el("tr", {}, ...["Parameter", "Fit", "Median", "Interval"].map((t, i) => el("th", { scope: "col", class: i ? "num" : null, text: t })))),
    el("tbody", {}, ...paramRows(r)))));
  const plots = el("div", { class: "plots" }, figure(`/jobs/${job.id}/plot.png`, `Fit of ${job.model}: measured and fitted reflectance in the planes of incidence, and the residuals`, "The fit and its residuals"));
  if (post) plots.append(figure(`/jobs/${job.id}/corner.png`, `Corner plot of the posterior of ${job.model}`, "The posterior: every pair of parameters"));
  article.append(plots);
  const downloads = [downloadLink(`/jobs/${job.id}`, `${job.model}-${job.id}.json`, "result (JSON)"), " · ",
    downloadLink(`/jobs/${job.id}/plot.png`, `${job.model}-fit.png`, "fit plot (PNG)")];
  if (post) downloads.push(" · ", downloadLink(`/jobs/${job.id}/corner.png`, `${job.model}-corner.png`, "corner plot (PNG)"));
  article.append(el("p", {}, "Download: ", ...downloads));
  article.append(exportButtons(job));
  return article;
}

// ----------------------------------------------------------------- exports
// One button per renderer: the job's own export when it made one (option
// `export`), else POST /export with its result; the document is saved as a file
// and its conversion error said beside the buttons.
function exportButtons(job) {
  const status = el("p", { class: "export-status", role: "status", "aria-live": "polite" });
  const buttons = Object.entries(state.targets).map(([target, about]) => {
    const button = el("button", { type: "button", "data-target": target, title: about, text: target,
                                  "aria-label": `Download ${job.model} as a ${target} material (${about})` });
    button.addEventListener("click", () => downloadExport(job, target, button, status));
    return button;
  });
  const label = el("span", { id: `x-${job.id}`, text: "Download the material for a renderer:" });
  const group = el("div", { class: "buttons exports", role: "group", "aria-labelledby": `x-${job.id}` }, label, ...buttons);
  return el("div", {}, group, status);
}

async function exportOf(job, target) {
  const r = job.result;
  const made = (r.exports || []).find((e) => e.target === target);
  if (made) return made;
  const body = { result: { model: r.model, params: r.params, channels: r.channels }, target };
  return getJSON("/export", { method: "POST", headers: { "Content-Type": "application/json" },
                              body: JSON.stringify(body) });
}

async function downloadExport(job, target, button, status) {
  button.disabled = true;
  status.classList.remove("error");
  status.textContent = `Exporting ${job.model} to ${target}…`;
  try {
    const made = await exportOf(job, target);
    const text = typeof made.document === "string" ? made.document : JSON.stringify(made.document, null, 2);
    // The library names the ending (a job stored before answers gave it has none: .txt);
    // the target too when they differ (two are JSON).
    const ending = made.extension || "txt";
    const name = ending === target ? `${job.model}.${target}` : `${job.model}.${target}.${ending}`;
    save(new Blob([text], { type: "application/octet-stream" }), name);
    const e = made.conversion_error;
    status.textContent = `Saved ${name}: ${e.exact ? "an exact" : "an approximate"} ${target} material; `
      + `RMS of ln(1 + f cos) ${fmt(e.rms_log_target)} (the fit's own ${fmt(e.rms_log_fit)}) against the ${e.against}.`;
  } catch (error) {
    status.classList.add("error");
    status.textContent = `${target}: ${(error.body && error.body.message) || error.message}`;
  } finally {
    button.disabled = false;
  }
}

// ------------------------------------------------------------------ recent
async function refreshRecent() {
  try {
    const jobs = await getJSON("/jobs?limit=20");
    $("#recent-table tbody").replaceChildren(...jobs.map((job) => el("tr", {},
      el("td", {}, el("a", { href: `#job=${job.id}`, text: job.id.slice(0, 8) })),
      el("td", { text: job.model }),
      el("td", { class: `status-${job.status}`, text: job.status }),
      el("td", { text: job.created.replace("T", " ").slice(0, 19) }))));
  } catch (error) { /* the list is a convenience; the form still works */ }
}

async function start() {
  wireToken();
  wireDrop();
  for (const axis of AXES) $(`#f-${axis}`).addEventListener("change", renderModelList);
  $("#model-list").addEventListener("change", updateCount);
  $("#models-extra").addEventListener("input", updateCount);
  $("#select-shown").addEventListener("click", () => { for (const d of $("#model-list").children) if (!d.hidden) d.querySelector("input").checked = true; updateCount(); });
  $("#clear-models").addEventListener("click", () => { for (const i of document.querySelectorAll("#model-list input")) i.checked = false; updateCount(); });
  $("#fit-form").addEventListener("submit", submit);
  $("#refresh-recent").addEventListener("click", refreshRecent);
  window.addEventListener("hashchange", follow);
  try {
    await Promise.all([loadModels(), loadLosses(), loadExamples(), loadTargets()]);
    const health = await getJSON("/health");
    $("#version").textContent = health.version;
  } catch (error) {
    showError(error.body || { field: null, message: String(error) });
  }
  document.body.dataset.ready = "true";
  refreshRecent();
  follow();
}

document.addEventListener("DOMContentLoaded", start);
