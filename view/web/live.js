// The live half of the report page, for the monitor (`eamos run
// --monitor`, `eamos monitor`): a panel per drone (current action,
// altitude, battery, lost or stuck), a bounded trail behind each marker,
// the list of signals, awaits, tokens between peers and peers lost as
// they happen, and the closest distance between two drones over mission
// time; and, only when the monitor holds the ground station's key, an
// abort button behind a confirmation.
//
// `EamosLive.attach(view)` wraps the view's `update(event)` so that the
// same events (the executor's own, as its log writes them) also feed the
// panel, which appears with the first event; `EamosLive.connect(view,
// url)` reads them from the monitor's server-sent events. A report opened
// from the disk never connects. Everything kept grows to a bound: the
// page's memory stays flat however long the flight.
"use strict";
var EamosLive = (function () {
  var TRAIL = 300, EVENTS = 200, SERIES = 600;
  var SVG = "http://www.w3.org/2000/svg";

  function el(ns, name, attrs, parent, text) {
    var e = ns ? document.createElementNS(ns, name) : document.createElement(name);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }

  function fmt(v) { return (Math.round(v * 10) / 10).toFixed(1); }

  function panel(view) {
    if (view.live) return view.live;
    var model = view.model;
    var root = document.getElementById("eamos-view") || document.body;
    var space = document.getElementById("space-views");
    var sec = el(null, "section", { id: "live" });
    root.insertBefore(sec, space);
    el(null, "h2", {}, sec, "Live");
    var status = el(null, "p", { id: "live-status" }, sec, "live");
    // Only a monitor holding the ground station's key serves an abort.
    if (document.body.dataset.abort) abortButton(sec, document.body.dataset.abort);
    var table = el(null, "table", { id: "drones-live" }, sec);
    var head = el(null, "tr", {}, table);
    ["drone", "action", "altitude", "battery", "state"].forEach(function (h) { el(null, "th", {}, head, h); });
    var rows = {};
    model.drones.forEach(function (d, i) {
      var tr = el(null, "tr", { "data-drone": i }, table);
      var name = el(null, "td", { "class": "name" }, tr);
      el(null, "span", { "class": "swatch", style: "background:" + d.colour }, name);
      name.appendChild(document.createTextNode(d.name));
      rows[d.name] = {
        tr: tr,
        action: el(null, "td", { "class": "action" }, tr, "–"),
        altitude: el(null, "td", { "class": "altitude" }, tr, "–"),
        battery: el(null, "td", { "class": "battery" }, tr, "–"),
        state: el(null, "td", { "class": "state" }, tr, "")
      };
    });
    var W = 560, H = 140;
    var chart = el(SVG, "svg", { id: "closest", "class": "view", viewBox: "0 0 " + W + " " + H }, sec);
    el(SVG, "title", {}, chart, "closest distance between two drones, over mission time");
    var line = el(SVG, "polyline", { "class": "closest-line", points: "" }, chart);
    var label = el(SVG, "text", { x: 8, y: 16, "class": "caption" }, chart, "closest distance: –");
    var events = el(null, "ol", { id: "events" }, sec);
    view.live = {
      status: status, rows: rows, chart: { svg: chart, line: line, label: label, W: W, H: H },
      events: events, positions: {}, trails: {}, series: [], lastClosest: -Infinity
    };
    return view.live;
  }

  // Behind a confirmation; the header tells the server that this page,
  // not a form of another site, asks.
  function abortButton(parent, url) {
    var p = el(null, "p", {}, parent);
    var button = el(null, "button", { id: "abort", type: "button" }, p, "Abort the mission…");
    var said = el(null, "span", { id: "abort-result" }, p);
    button.onclick = function () {
      if (!window.confirm("Abort the mission? Every drone cancels what it does and goes to its failsafe.")) return;
      button.disabled = true;
      said.textContent = " sending the abort…";
      fetch(url, { method: "POST", headers: { "X-Eamos-Confirm": "abort" } })
        .then(function (r) {
          return r.text().then(function (t) { said.textContent = " " + (r.ok ? "" : "refused: ") + t; });
        })
        .catch(function (e) { said.textContent = " failed: " + e; })
        .then(function () { button.disabled = false; });
    };
  }

  function note(live, event, text, cls) {
    var li = el(null, "li", { "class": cls || "" }, null, "[" + fmt(event.time) + " s] " + event.drone + ": " + text);
    live.events.insertBefore(li, live.events.firstChild);
    while (live.events.childNodes.length > EVENTS) live.events.removeChild(live.events.lastChild);
  }

  function setState(live, drone, text, cls) {
    var r = live.rows[drone];
    if (!r) return;
    r.state.textContent = text;
    r.tr.className = cls || "";
  }

  // The trail behind a drone: its last TRAIL positions, one point added
  // (and the oldest dropped) per sample rather than the line written
  // again, so that a hundred drones' samples cost the page little.
  function trail(view, live, event) {
    var i = EamosView.droneIndex(view, event.drone);
    if (i < 0) return;
    var p = event.position, q = view.plan.at([p.x, p.y, p.z]);
    var path = live.trails[i];
    if (!path) {
      path = live.trails[i] = el(SVG, "polyline", { "class": "trail", "data-drone": i, stroke: view.model.drones[i].colour, points: "" }, null);
      var g = view.plan.svg.querySelector("g.live");
      g.insertBefore(path, g.firstChild);
    }
    var point = view.plan.svg.createSVGPoint();
    point.x = q[0];
    point.y = q[1];
    path.points.appendItem(point);
    if (path.points.numberOfItems > TRAIL) path.points.removeItem(0);
  }

  // The closest two drones now, sampled at most twice a mission second.
  function closest(live, event) {
    var p = event.position;
    live.positions[event.drone] = [p.x, p.y, p.z];
    if (event.time - live.lastClosest < 0.5) return;
    var names = Object.keys(live.positions), best = Infinity, pair = null;
    for (var a = 0; a < names.length; a++) {
      for (var b = a + 1; b < names.length; b++) {
        var u = live.positions[names[a]], v = live.positions[names[b]];
        var d = Math.hypot(u[0] - v[0], u[1] - v[1], u[2] - v[2]);
        if (d < best) { best = d; pair = names[a] + "–" + names[b]; }
      }
    }
    if (!pair) return;
    live.lastClosest = event.time;
    live.series.push([event.time, best]);
    if (live.series.length > SERIES) live.series.shift();
    var c = live.chart, t0 = live.series[0][0], t1 = Math.max(event.time, t0 + 1);
    var top = Math.max.apply(null, live.series.map(function (s) { return s[1]; })) || 1;
    c.line.setAttribute("points", live.series.map(function (s) {
      return (10 + (s[0] - t0) / (t1 - t0) * (c.W - 20)) + "," + (c.H - 10 - s[1] / top * (c.H - 40));
    }).join(" "));
    c.label.textContent = "closest distance: " + fmt(best) + " m (" + pair + "), at most " + fmt(top) + " m shown";
    c.svg.setAttribute("data-closest", best);
  }

  function update(view, event) {
    var live = panel(view), row = live.rows[event.drone];
    switch (event.event) {
      case "telemetry":
        if (!event.position) return;
        trail(view, live, event);
        closest(live, event);
        if (row) {
          row.altitude.textContent = fmt(event.altitude) + " m";
          row.battery.textContent = fmt(event.battery) + " %";
        }
        return;
      case "action_started":
      case "action_resumed":
        if (row) row.action.textContent = event.action + "(" + (event.args || []).join(", ") + ")";
        return;
      case "action_finished":
        if (row && event.outcome !== "ok") row.action.textContent = event.action + ": " + event.outcome;
        return;
      case "fired":
        if (event.kind === "signal" || event.kind === "await") note(live, event, event.kind + " " + event.label, event.kind);
        return;
      case "bridge_received":
        note(live, event, "token from " + event.from + " (bridge " + event.bridge + ")", "bridge");
        return;
      case "peer_lost":
        setState(live, event.peer, "lost (seen by " + event.drone + ")", "lost");
        note(live, event, "lost " + event.peer, "lost");
        return;
      case "peer_back":
        setState(live, event.peer, "", "");
        note(live, event, event.peer + " is back");
        return;
      case "stuck":
        setState(live, event.drone, "stuck on " + event.lost.join(", ") + ": " + event.policy, "stuck");
        note(live, event, "stuck on " + event.lost.join(", ") + ": " + event.policy, "stuck");
        return;
      case "peer_stuck":
        setState(live, event.peer, "stuck on " + event.lost + ": " + event.policy, "stuck");
        return;
      case "abort_received":
      case "failsafe":
        note(live, event, event.event.replace("_", " ") + ": " + (event.reason || ""), "alert");
        return;
      case "mission_ended":
        note(live, event, "mission ended");
        return;
      case "stopped":
        if (row && event.reason !== "completed") setState(live, event.drone, "stopped: " + event.reason, "stopped");
        else if (row) row.state.textContent = "done";
        return;
    }
  }

  // How long events take from the monitor to this page (`sent`, stamped
  // by the server's feed): once handled, and once the frame that shows
  // them is drawn. Histograms of half-milliseconds of a fixed size, so
  // that measuring does not grow the page's memory however long it runs;
  // the monitor's latency benchmark reads them (`EamosLive.latency`).
  var BUCKET = 0.5, BUCKETS = 10000;
  function Histogram() { this.counts = new Uint32Array(BUCKETS + 1); this.n = 0; this.max = 0; }
  Histogram.prototype.add = function (ms) {
    this.counts[Math.min(BUCKETS, Math.max(0, Math.floor(ms / BUCKET)))]++;
    this.n++;
    if (ms > this.max) this.max = ms;
  };
  Histogram.prototype.quantile = function (q) {
    if (!this.n) return null;
    var want = Math.ceil(q * this.n), seen = 0;
    for (var i = 0; i < BUCKETS; i++) {
      seen += this.counts[i];
      if (seen >= want) return (i + 1) * BUCKET;
    }
    return this.max;
  };
  Histogram.prototype.summary = function () {
    return { count: this.n, p50: this.quantile(0.5), p99: this.quantile(0.99), max: this.max };
  };

  function clock() { return performance.timeOrigin + performance.now(); }

  function latencies(view) {
    if (!view.latency) view.latency = { handled: new Histogram(), painted: new Histogram(), pending: [], frame: false };
    return view.latency;
  }

  function measure(view, sent) {
    var l = latencies(view);
    l.handled.add(clock() - sent);
    if (l.pending.length < 100000) l.pending.push(sent);
    if (l.frame) return;
    l.frame = true;
    requestAnimationFrame(function () {
      var t = clock();
      l.pending.forEach(function (s) { l.painted.add(t - s); });
      l.pending = [];
      l.frame = false;
    });
  }

  // What was measured so far; `reset` starts again (after a warm-up).
  function latency(view, reset) {
    var l = latencies(view);
    var said = { handled: l.handled.summary(), painted: l.painted.summary() };
    if (reset) { l.handled = new Histogram(); l.painted = new Histogram(); }
    return said;
  }

  function attach(view) {
    var drawn = view.update;
    view.update = function (event) {
      drawn(event);
      update(view, event);
    };
    return view;
  }

  function connect(view, url) {
    var source = new EventSource(url);
    source.onmessage = function (m) {
      var event = JSON.parse(m.data);
      view.update(event);
      if (typeof event.sent === "number") measure(view, event.sent);
    };
    source.onopen = function () { panel(view).status.textContent = "live: connected"; };
    source.onerror = function () {
      panel(view).status.textContent = "live: disconnected (the run may have ended); retrying";
    };
    view.source = source;
    return source;
  }

  return { attach: attach, connect: connect, latency: latency };
})();
