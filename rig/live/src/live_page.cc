// The live view's page: one HTML file with its CSS and JavaScript, no
// external fetches (the station may have no internet). It polls state.json
// four times a second and reloads frame.jpg when the frame number changes
// (or shows stream.mjpg with ?mjpeg=1). One column under 760 px of width
// (a phone held next to the robot: warnings, camera, trajectory, progress,
// estimates), two above it.
//
// Colours a test looks for in a screenshot (tests/app/watch_cli_test.cc):
// the tag's outline is drawn into the JPEG in magenta (live_state.h), the
// trajectory in #0066ff, the warnings box is #c62828 when there are any.
// After each update the page writes its layout into <body data-*> (the
// viewport's width, the document's scroll width, the image's and the
// canvas's boxes) so a headless browser's --dump-dom can check it.
#include "odocal/live/live_server.h"

namespace odocal::live {

const std::string& LivePageHtml() {
  static const std::string kPage = R"odocal(<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>odocal live</title>
<style>
*{box-sizing:border-box}
html{-webkit-text-size-adjust:100%}
body{margin:0;font:16px/1.4 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;background:#eceff1;color:#111}
header{padding:8px 12px;background:#263238;color:#fff;display:flex;flex-wrap:wrap;gap:2px 16px;align-items:baseline}
header h1{font-size:18px;margin:0}
#status{font-size:14px;color:#cfd8dc;overflow-wrap:anywhere;min-width:0}
main{display:grid;grid-template-columns:minmax(0,3fr) minmax(0,2fr);gap:12px;padding:12px;max-width:1600px;margin:0 auto}
@media (max-width:760px){main{grid-template-columns:minmax(0,1fr);gap:8px;padding:8px}}
section{background:#fff;border-radius:6px;padding:8px 10px;min-width:0;overflow-wrap:anywhere}
h2{font-size:13px;margin:0 0 6px;color:#546e7a;text-transform:uppercase;letter-spacing:.05em}
h2 .nt{text-transform:none;letter-spacing:0}
#warnings{grid-column:1/-1;background:#2e7d32;color:#fff}
#warnings.bad{background:#c62828}
#warnings h2{color:#fff}
#warnlist{margin:0;padding-left:20px;font-weight:600}
#cam{display:block;width:100%;height:auto;min-height:40px;background:#000}
#pose{font:15px/1.5 ui-monospace,"DejaVu Sans Mono",monospace;margin-top:6px}
#pose.old{color:#b71c1c}
#traj{display:block;width:100%}
#runbar{width:100%;height:14px}
table{width:100%;border-collapse:collapse}
td{padding:3px 4px;border-top:1px solid #eceff1;vertical-align:top}
td.v{font-family:ui-monospace,"DejaVu Sans Mono",monospace;text-align:right}
</style>
</head>
<body>
<header><h1>odocal live</h1><span id="status">connecting&hellip;</span></header>
<main>
<section id="warnings" role="status" aria-live="polite"><h2>Warnings</h2><ul id="warnlist"><li>none</li></ul></section>
<section id="camera"><h2>Camera</h2><img id="cam" alt="camera image with the tag's outline"><div id="pose">pose: &mdash;</div></section>
<section id="trajectory"><h2>Trajectory (world, from above)</h2><canvas id="traj" aria-label="trajectory over a floor grid"></canvas></section>
<section id="progress"><h2>Progress</h2><div id="plan">no plan</div><div id="run"></div><progress id="runbar" max="1" value="0"></progress></section>
<section id="estimates"><h2>Estimates <span class=nt>&plusmn; 1&sigma;</span></h2><table><tbody id="est"><tr><td>none yet</td></tr></tbody></table></section>
</main>
<script>
"use strict";
const $ = id => document.getElementById(id);
const useMjpeg = new URLSearchParams(location.search).has("mjpeg");
const cam = $("cam"), canvas = $("traj");
let lastSeq = 0, imgBusy = false, state = null;
cam.onload = cam.onerror = () => { imgBusy = false; layout(); };
if (useMjpeg) cam.src = "stream.mjpg";

function esc(t) { return String(t).replace(/[&<>"]/g, c => ({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;"}[c])); }
// A value with its sigma, to the sigma's second significant digit.
function pm(v, s, unit) {
  const u = unit ? " " + unit : "";
  if (!(s > 0)) return Number(v).toPrecision(6) + u;
  const d = Math.min(10, Math.max(0, 1 - Math.floor(Math.log10(s))));
  return v.toFixed(d) + " &plusmn; " + s.toFixed(d) + u;
}

function render(s) {
  const f = s.frame;
  let st = s.source ? esc(s.source) : "";
  if (f) st += (st ? " &middot; " : "") + "frame " + f.seq + " at " + f.t_s.toFixed(2) + " s &middot; " +
                 f.fps.toFixed(1) + " fps" + (f.age_s > 2 ? " &middot; <b>no new frame for " + f.age_s.toFixed(0) + " s</b>" : "");
  else st += (st ? " &middot; " : "") + "waiting for the first frame";
  $("status").innerHTML = st;
  if (!useMjpeg && f && f.seq !== lastSeq && !imgBusy) {
    imgBusy = true;
    lastSeq = f.seq;
    cam.src = "frame.jpg?seq=" + f.seq;
  }
  const p = s.pose, pe = $("pose");
  if (p) {
    pe.innerHTML = "x " + pm(p.x_mm, p.sigma_x_mm, "mm") + "<br>y " + pm(p.y_mm, p.sigma_y_mm, "mm") +
                   "<br>&theta; " + pm(p.heading_deg, p.sigma_heading_deg, "&deg;") +
                   (p.current ? "" : "<br>(last seen at " + p.t_s.toFixed(2) + " s)");
    pe.className = p.current ? "" : "old";
  } else {
    pe.textContent = s.tag.seen ? "tag seen, no pose yet" : "no pose: tag not seen";
  }
  const w = s.warnings;
  $("warnings").className = w.length ? "bad" : "";
  $("warnlist").innerHTML = w.length ? w.map(x => "<li>" + esc(x.text) + "</li>").join("") : "<li>none</li>";
  const g = s.progress;
  if (g) {
    $("plan").textContent = g.plan_label || "plan";
    $("run").textContent = g.run_total > 0 ? "run " + g.run_index + " of " + g.run_total + (g.run_label ? ": " + g.run_label : "")
                                           : (g.run_label || "no runs");
    $("runbar").value = g.run_total > 0 ? g.run_index / g.run_total : 0;
  }
  $("est").innerHTML = s.estimates.length
      ? s.estimates.map(e => "<tr><td>" + esc(e.name) + "</td><td class=v>" + pm(e.value, e.sigma, esc(e.unit)) + "</td></tr>").join("")
      : "<tr><td>none yet</td></tr>";
  draw(s);
  layout();
}

function lost() {
  $("warnings").className = "bad";
  $("warnlist").innerHTML = "<li>no answer from odocal (stopped?)</li>";
  $("status").textContent = "disconnected";
}

// The trajectory over a floor grid: 100 mm lines, metres labelled; x to the
// right, y up (REP-103 seen from above); the tag's pose as a green arrow.
function draw(s) {
  const dpr = window.devicePixelRatio || 1;
  const W = canvas.clientWidth, H = Math.round(Math.min(W * 0.8, window.innerHeight * 0.7));
  canvas.style.height = H + "px";
  canvas.width = Math.round(W * dpr);
  canvas.height = Math.round(H * dpr);
  const c = canvas.getContext("2d");
  c.setTransform(dpr, 0, 0, dpr, 0, 0);
  c.fillStyle = "#fff";
  c.fillRect(0, 0, W, H);
  const pts = s.trajectory_mm.slice();
  if (s.pose) pts.push([s.pose.x_mm, s.pose.y_mm]);
  let x0 = -500, x1 = 500, y0 = -500, y1 = 500;
  if (pts.length) {
    x0 = Math.min(...pts.map(q => q[0])); x1 = Math.max(...pts.map(q => q[0]));
    y0 = Math.min(...pts.map(q => q[1])); y1 = Math.max(...pts.map(q => q[1]));
  }
  const pad = 150, minSpan = 1000;
  const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
  const sx = Math.max(minSpan, x1 - x0 + 2 * pad), sy = Math.max(minSpan, y1 - y0 + 2 * pad);
  const ml = 34, mr = 14, mt = 8, mb = 32, pw = W - ml - mr, ph = H - mt - mb;
  if (pw < 20 || ph < 20) return;
  const k = Math.min(pw / sx, ph / sy);
  const X = x => ml + pw / 2 + (x - cx) * k, Y = y => mt + ph / 2 - (y - cy) * k;
  const xa = cx - pw / 2 / k, xb = cx + pw / 2 / k, ya = cy - ph / 2 / k, yb = cy + ph / 2 / k;
  c.save();
  c.beginPath(); c.rect(ml, mt, pw, ph); c.clip();
  const each = (a, b, step, fn) => { for (let i = Math.ceil(a / step); i * step <= b; ++i) fn(i * step); };
  const lines = (step, style, width) => {
    c.strokeStyle = style; c.lineWidth = width; c.beginPath();
    each(xa, xb, step, x => { c.moveTo(X(x), mt); c.lineTo(X(x), mt + ph); });
    each(ya, yb, step, y => { c.moveTo(ml, Y(y)); c.lineTo(ml + pw, Y(y)); });
    c.stroke();
  };
  // 100 mm lines, metre lines darker, labels at the first spacing that leaves room.
  if (100 * k >= 5) lines(100, "#e3e7ea", 1);
  const lab = [100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000].find(v => v * k >= 45) || 100000;
  lines(lab, "#cfd8dc", 1);
  if (1000 * k >= 5) lines(1000, "#90a4ae", 1);
  c.strokeStyle = "#607d8b"; c.lineWidth = 1.5; c.beginPath();
  c.moveTo(X(0), mt); c.lineTo(X(0), mt + ph); c.moveTo(ml, Y(0)); c.lineTo(ml + pw, Y(0)); c.stroke();
  const t = s.trajectory_mm;
  if (t.length) {
    c.strokeStyle = "#0066ff"; c.lineWidth = 3; c.lineJoin = c.lineCap = "round"; c.beginPath();
    c.moveTo(X(t[0][0]), Y(t[0][1]));
    for (const q of t) c.lineTo(X(q[0]), Y(q[1]));
    if (s.pose) c.lineTo(X(s.pose.x_mm), Y(s.pose.y_mm));
    c.stroke();
    c.fillStyle = "#fff"; c.beginPath(); c.arc(X(t[0][0]), Y(t[0][1]), 5, 0, 2 * Math.PI); c.fill(); c.stroke();
  }
  if (s.pose) {
    const a = s.pose.heading_deg * Math.PI / 180, px = X(s.pose.x_mm), py = Y(s.pose.y_mm), r = 11;
    c.fillStyle = s.pose.current ? "#00a651" : "#9e9e9e"; c.beginPath();
    c.moveTo(px + r * Math.cos(a), py - r * Math.sin(a));
    c.lineTo(px + r * Math.cos(a + 2.5), py - r * Math.sin(a + 2.5));
    c.lineTo(px + r * Math.cos(a - 2.5), py - r * Math.sin(a - 2.5));
    c.closePath(); c.fill();
  }
  c.restore();
  c.fillStyle = "#37474f"; c.font = "12px system-ui,sans-serif"; c.textAlign = "center"; c.textBaseline = "top";
  const m = v => String(Number((v / 1000).toFixed(3)));
  each(xa, xb, lab, x => c.fillText(m(x), X(x), mt + ph + 3));
  c.textAlign = "right"; c.textBaseline = "middle";
  each(ya, yb, lab, y => c.fillText(m(y), ml - 4, Y(y)));
  c.textAlign = "right"; c.textBaseline = "top"; c.fillText("x (m)", ml + pw, mt + ph + 18);
  c.textAlign = "left"; c.fillText("y (m)", 2, 0);
  c.strokeStyle = "#90a4ae"; c.lineWidth = 1; c.strokeRect(ml, mt, pw, ph);
}

function box(e) { const r = e.getBoundingClientRect(); return [r.left, r.top, r.width, r.height].map(Math.round).join(","); }
function layout() {
  const b = document.body.dataset;
  b.viewportWidth = window.innerWidth;
  b.scrollWidth = document.documentElement.scrollWidth;
  b.cam = box(cam);
  b.camLoaded = cam.naturalWidth > 0 ? "1" : "0";
  b.traj = box(canvas);
  b.warnings = box($("warnings"));
  b.frameSeq = lastSeq;
}

function poll() {
  fetch("state.json", {cache: "no-store"})
    .then(r => r.json())
    .then(s => { state = s; render(s); })
    .catch(lost)
    .finally(() => setTimeout(poll, 250));
}
window.addEventListener("resize", () => { if (state) draw(state); layout(); });
poll();
</script>
</body>
</html>
)odocal";
  return kPage;
}

}  // namespace odocal::live
