// vidtrack view: step through the footage, click the scene and the corrections.
"use strict";
const $ = (id) => document.getElementById(id);
let state = null, view = null, index = 0, tool = null, clicks = [];
// the zoom: the frame pixel it is centred on, the last URL asked for, one request at a time
let zoomAt = null, zoomUrl = null, zoomBusy = false;
// the frame pixel at the centre of the zoom shown (pixel centres at integers)
let zoomShown = null;

const HINTS = {
  origin: "click the origin O (the centre of the blade shaft)",
  axes: ["click a point along +X from O", "click a point along the second axis (+Y or +Z) from O"],
  ruler: ["click one end of the ruler", "click the other end of the ruler"],
  target: "click the object to follow in this frame",
  point: "click the object's centre in this frame (a point placed by hand)",
};

function say(text, kind) {
  const m = $("message");
  m.textContent = text || "";
  m.className = kind || "";
}

async function api(path, body) {
  const opts = body === undefined ? {} : {
    method: "POST", headers: {"Content-Type": "application/json"},
    body: JSON.stringify(body)};
  const r = await fetch(path, opts);
  const data = await r.json();
  if (!r.ok) throw new Error(data.error || ("HTTP " + r.status));
  return data;
}

async function loadState(answer) {
  state = answer || await api("/api/state");
  $("run").textContent = state.run + (state.throw ? ", throw " + state.throw : "");
  const err = $("scene-error");
  err.hidden = !state.scene_error;
  err.textContent = state.scene_error ? "the scene does not load yet: " + state.scene_error
                                      : "";
  const pick = $("throw");
  $("throw-pick").hidden = !state.throws.length;
  if (!pick.options.length) for (const t of state.throws) pick.add(new Option(t, t));
  if (state.throw) pick.value = state.throw;
  $("notes").innerHTML = "";
  for (const n of state.notes) {
    const li = document.createElement("li");
    li.textContent = n;
    $("notes").appendChild(li);
  }
  const sel = $("view");
  if (!sel.options.length) {
    for (const name of Object.keys(state.views)) sel.add(new Option(name, name));
    view = sel.value;
  }
  showFit(state.fit);
}

function showFit(fit) {
  const s = $("fit-status");
  s.textContent = fit.state === "idle" ? "" : fit.state + (fit.message ? ": " + fit.message : "");
  s.className = fit.state === "failed" ? "error" : "";
  $("fit").disabled = fit.state === "running";
}

async function show(i) {
  const v = state.views[view];
  if (document.activeElement !== $("fps")) $("fps").value = v.fps === null ? "" : v.fps;
  index = Math.max(0, Math.min(v.frames - 1, i));
  $("index").value = index; $("index").max = v.frames - 1;
  $("slider").value = index; $("slider").max = v.frames - 1;
  $("count").textContent = "of " + v.frames;
  const img = $("frame");
  const loaded = new Promise((ok) => { img.onload = ok; img.onerror = ok; });
  img.src = "/frame/" + encodeURIComponent(view) + "/" + index + ".png?t=" + Date.now();
  const info = await api("/api/frame/" + encodeURIComponent(view) + "/" + index);
  await loaded;
  img.dataset.frame = String(info.frame);
  if (!zoomAt && info.u_px !== null) zoomAt = [info.u_px, info.v_px];
  zoom();
  $("exclude").textContent = info.excluded ? "include this frame" : "exclude this frame";
  $("info").textContent = [
    "frame " + info.frame + "   t = " + info.t_s.toFixed(5) + " s",
    "flags: " + info.flag_text + (info.reason ? "  (" + info.reason + ")" : ""),
    "measured: " + (info.u_px === null ? "-" : info.u_px.toFixed(2) + ", " + info.v_px.toFixed(2)),
    "placed by hand: " + (info.manual_px ? info.manual_px.join(", ") : "-"),
    "excluded: " + (info.excluded ? "yes" : "no"),
    "target: " + (v.target ? "frame " + v.target.frame + " at " + v.target.at_px.join(", ")
                           : "-"),
  ].join("\n");
}

function setTool(name) {
  tool = tool === name ? null : name;
  clicks = [];
  for (const b of document.querySelectorAll("button.tool"))
    b.classList.toggle("active", b.dataset.tool === tool);
  hint();
}

function hint() {
  if (!tool) { say(""); return; }
  const h = HINTS[tool];
  say(Array.isArray(h) ? h[clicks.length] : h);
}

// A click on the drawn frame -> the footage's pixel (pixel centres at integers).
function framePixel(ev) {
  const img = $("frame"), r = img.getBoundingClientRect();
  const scale = state.views[view].scale;
  const x = (ev.clientX - r.left) * img.naturalWidth / r.width;
  const y = (ev.clientY - r.top) * img.naturalHeight / r.height;
  return [+(((x + 0.5) / scale) - 0.5).toFixed(2), +(((y + 0.5) / scale) - 0.5).toFixed(2)];
}

// The zoom centred on px (or where it was), asked for once the previous one has come.
function zoom(px) {
  if (px) zoomAt = px;
  if (!zoomAt || zoomBusy) return;
  const url = "/zoom/" + encodeURIComponent(view) + "/" + index + ".png?u=" + zoomAt[0] +
              "&v=" + zoomAt[1];
  if (url === zoomUrl) return;
  const z = $("zoom");
  const centre = zoomAt.map((x) => Math.floor(x + 0.5));
  zoomBusy = true;
  zoomUrl = url;
  z.onload = () => { zoomBusy = false; z.hidden = false; zoomShown = centre; zoom(); };
  z.onerror = () => { zoomBusy = false; z.hidden = true; zoom(); };
  z.src = url;
  $("zoom-at").textContent = "zoom: around " + zoomAt.join(", ");
}

async function edit(body) {
  try {
    const r = await api("/api/edit", Object.assign({view: view}, body));
    say("wrote " + r.written.join(", ") +
        (r.scene_error ? "; scene.toml still: " + r.scene_error : ""), "ok");
    await loadState();
    await show(index);
  } catch (e) {
    say(e.message, "error");
  }
}

// A click on the zoom -> the footage's pixel it shows: each frame pixel is a block of
// state.zoom.factor drawn pixels, the centre pixel's block state.zoom.half_px blocks in.
function zoomPixel(ev) {
  const z = $("zoom"), r = z.getBoundingClientRect(), f = state.zoom.factor;
  const x = (ev.clientX - r.left) * z.naturalWidth / r.width;
  const y = (ev.clientY - r.top) * z.naturalHeight / r.height;
  return [+(zoomShown[0] + x / f - state.zoom.half_px - 0.5).toFixed(2),
          +(zoomShown[1] + y / f - state.zoom.half_px - 0.5).toFixed(2)];
}

async function onFrameClick(ev) {
  await place(framePixel(ev));
}

async function onZoomClick(ev) {
  if (zoomShown) await place(zoomPixel(ev));
}

// A pixel clicked (on the frame or on the zoom) -> the tool's edit.
async function place(px) {
  if (!tool) { say("choose what to click first (origin, axes, ruler, target, point)"); return; }
  const frame = Number($("frame").dataset.frame);
  clicks.push(px);
  const t = tool;
  if (t === "origin") await edit({set: "origin", at_px: px});
  else if (t === "target") await edit({set: "target", frame: frame, at_px: px});
  else if (t === "point") { await edit({set: "point", frame: frame, at_px: px}); return; }
  else if (clicks.length < 2) { hint(); return; }
  else if (t === "axes") await edit({set: "axes", first_px: clicks[0], second_px: clicks[1]});
  else if (t === "ruler") await edit({set: "ruler", from_px: clicks[0], to_px: clicks[1],
                                      length_m: Number($("ruler-length").value)});
  clicks = [];
  tool = null;
  for (const b of document.querySelectorAll("button.tool")) b.classList.remove("active");
}

async function pollFit() {
  const fit = await api("/api/fit");
  showFit(fit);
  if (fit.state === "running") { setTimeout(pollFit, 500); return; }
  await loadState();
  await show(index);
}

function init() {
  $("frame").addEventListener("click", onFrameClick);
  $("frame").addEventListener("mousemove", (ev) => zoom(framePixel(ev)));
  $("zoom").addEventListener("click", onZoomClick);
  $("throw").onchange = async () => {
    try {
      await loadState(await api("/api/throw", {throw: $("throw").value}));
      zoomAt = null; zoomShown = null;
      await show(0);
      document.body.dataset.throw = state.throw;   // the throw picked is shown
    } catch (e) { say(e.message, "error"); }
  };
  $("prev").onclick = () => show(index - 1);
  $("next").onclick = () => show(index + 1);
  $("index").onchange = () => show(Number($("index").value));
  $("slider").oninput = () => show(Number($("slider").value));
  $("view").onchange = () => {
    view = $("view").value; zoomAt = null; zoomShown = null; show(0);
  };
  for (const b of document.querySelectorAll("button.tool")) {
    b.onclick = () => setTool(b.dataset.tool);
  }
  $("exclude").onclick = () => edit({set: "exclude", frame: Number($("frame").dataset.frame),
                                     excluded: $("exclude").textContent.startsWith("exclude")});
  $("remove-point").onclick = () => edit({set: "point", frame: Number($("frame").dataset.frame),
                                          at_px: null});
  $("remove-target").onclick = () => edit({set: "target", at_px: null});
  $("set-fps").onclick = () => edit({set: "fps", fps: Number($("fps").value)});
  $("fit").onclick = async () => {
    try { showFit(await api("/api/fit", {})); pollFit(); } catch (e) { say(e.message, "error"); }
  };
  document.addEventListener("keydown", (ev) => {
    if (ev.target.tagName === "INPUT") return;
    if (ev.key === "ArrowLeft") show(index - 1);
    if (ev.key === "ArrowRight") show(index + 1);
    if (ev.key === "Escape") setTool(null);
  });
  loadState().then(() => show(0)).then(() => { document.body.dataset.ready = "1"; })
    .catch((e) => say(e.message, "error"));
}
init();
