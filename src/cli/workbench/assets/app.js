// errmap workbench: the page's own script. Shows a chart point's value when pointing at
// it, and runs the live capture page (Start, Stop, Server-Sent Events). No other host.
"use strict";
(function () {
  const tip = document.getElementById("tip");
  function show(ev, text) {
    tip.textContent = text;
    tip.hidden = false;
    tip.style.left = (ev.clientX + 14) + "px";
    tip.style.top = (ev.clientY + 14) + "px";
  }
  document.addEventListener("mouseover", function (ev) {
    const t = ev.target.closest && ev.target.closest("[data-tip]");
    if (t) { show(ev, t.getAttribute("data-tip")); } else { tip.hidden = true; }
  });
  document.addEventListener("mousemove", function (ev) {
    if (!tip.hidden) { tip.style.left = (ev.clientX + 14) + "px"; tip.style.top = (ev.clientY + 14) + "px"; }
  });
  const token = document.querySelector("meta[name=errmap-form-token]").content;
  function post(url, body) {
    return fetch(url, {
      method: "POST",
      headers: { "Content-Type": "application/json", "X-Errmap-Form-Token": token },
      body: JSON.stringify(body || {}),
    }).then(function (r) { return r.json().then(function (j) { return { status: r.status, body: j }; }); });
  }
  // A page whose result is being made: look again shortly (it fills in when ready).
  if (document.getElementById("pending")) { setTimeout(function () { location.reload(); }, 250); }
  const live = document.getElementById("live");
  if (!live) { return; }
  const $ = function (id) { return document.getElementById(id); };
  function say(text, bad) { $("live-message").textContent = text; $("live-message").className = bad ? "bad" : "ok"; }
  $("start").addEventListener("click", function () {
    const source = document.querySelector("input[name=source]:checked").value;
    const body = source === "port" ? { port: $("port").value }
      : { model: $("model").value, plan: $("plan").value, speed: parseFloat($("speed").value) || 1 };
    post("/api/live/start", body).then(function (r) {
      if (r.status === 200) { say("capture started into " + r.body.session); } else { say(r.body.error, true); }
    });
  });
  $("stop").addEventListener("click", function () {
    post("/api/live/stop").then(function (r) {
      if (r.status === 200) { say("stopped: " + r.body.session); } else { say(r.body.error, true); }
    });
  });
  const events = new EventSource("/api/live/events");
  events.addEventListener("state", function (ev) {
    const s = JSON.parse(ev.data);
    $("frames").textContent = String(s.updates);
    $("state").textContent = s.state;
    $("session").innerHTML = s.session ? '<a href="/session/' + encodeURI(s.session) + '">' + s.session + "</a>" : "—";
    $("bytes").textContent = s.bytes + " B";
    $("samples").textContent = String(s.samples);
    $("run").textContent = s.run === null ? "—" : String(s.run);
    $("target").textContent = s.target === null ? "—" : String(s.target);
    // A rotary board's readings are an angle (°) and an angular error (″).
    const rotary = s.rotary_axis !== null;
    $("position-label").textContent = rotary ? "axis " + s.rotary_axis + " angle" : "scale position";
    if (rotary) {
      $("position").textContent = s.angle_deg === null ? "—" : s.angle_deg.toFixed(4) + "°";
      $("reading").textContent = s.error_arcsec === null ? "—" : s.error_arcsec.toFixed(2) + "″";
    } else {
      $("position").textContent = s.position_mm === null ? "—" : s.position_mm.toFixed(4) + " mm";
      $("reading").textContent = s.error_um === null ? "—" : s.error_um.toFixed(3) + " µm";
    }
    $("health").textContent = s.crc_failures + " CRC failures, " + s.resyncs + " resyncs, " + s.seq_gaps + " seq gaps, " + s.flagged + " flagged";
    $("start").disabled = s.state === "running";
    $("stop").disabled = s.state !== "running";
    if (s.error) { say(s.error, true); }
    const rows = s.targets.map(function (t) {
      return "<tr><td class=n>" + t.run + "</td><td>" + (t.direction > 0 ? "↑" : "↓") + "</td><td class=n>" + t.target +
        "</td><td class=n>" + (rotary ? t.position_deg.toFixed(4) + "°" : t.position_mm.toFixed(3) + " mm") +
        "</td><td class=n>" + (rotary ? t.error_arcsec.toFixed(2) + "″" : t.error_um.toFixed(3) + " µm") +
        "</td><td class=n>" + t.n + "</td></tr>";
    });
    $("targets").innerHTML = rows.join("");
  });
})();
