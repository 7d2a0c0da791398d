// The mission report page: draws the model `eamos view` embeds.
//
// `EamosView.render(root, model)` draws everything once, from the model
// alone, and returns a view whose `update(event)` changes only what is
// live. An event is one of the executor's mission events, as its JSON-lines
// log writes them (`eamos_exec::event::Event`, one vocabulary for every
// consumer): `{"drone": "D1", "event": "telemetry", "position": {"x", "y",
// "z"}}` (metres in the fleet frame, as the homes and legs) moves the
// drone's marker in the plan and side views; `{"drone": "D1", "event": "marking", "marked":
// [place ids]}` marks the places the drone holds in the graph. Other events
// are ignored here (`live.js` reads the rest). The static report never
// calls `update`; the monitor feeds the page with a run's events.
//
// Plain SVG drawn by hand for the plan, side and timeline views; the
// mission graph is laid out by dagre (inlined before this script).
"use strict";
var EamosView = (function () {
  var SVG = "http://www.w3.org/2000/svg";

  function svg(name, attrs, parent, text) {
    var e = document.createElementNS(SVG, name);
    for (var k in attrs) {
      if (attrs[k] !== undefined && attrs[k] !== null) e.setAttribute(k, attrs[k]);
    }
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }

  function html(name, attrs, parent, text) {
    var e = document.createElement(name);
    for (var k in attrs) {
      if (attrs[k] !== undefined && attrs[k] !== null) e.setAttribute(k, attrs[k]);
    }
    if (text !== undefined) e.textContent = text;
    if (parent) parent.appendChild(e);
    return e;
  }

  function fmt(v) {
    return (Math.round(v * 10) / 10).toString();
  }

  // A round step for grid lines and axis ticks: 1, 2 or 5 times a power of ten.
  function niceStep(span, count) {
    var raw = span / count;
    var p = Math.pow(10, Math.floor(Math.log10(raw)));
    var m = raw / p;
    return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
  }

  // Bounds of a list of [a, b] pairs, at least `least` across, with a margin.
  function bounds(points, least) {
    var lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
    points.forEach(function (p) {
      for (var i = 0; i < 2; i++) {
        lo[i] = Math.min(lo[i], p[i]);
        hi[i] = Math.max(hi[i], p[i]);
      }
    });
    if (!points.length) { lo = [-1, -1]; hi = [1, 1]; }
    for (var i = 0; i < 2; i++) {
      var mid = (lo[i] + hi[i]) / 2, half = Math.max(hi[i] - lo[i], least) / 2 * 1.1;
      lo[i] = mid - half;
      hi[i] = mid + half;
    }
    return { lo: lo, hi: hi };
  }

  function lineLink(line) {
    return line ? "#L" + line : null;
  }

  // ---- plan view: from above, north up, east right --------------------
  function planView(parent, model) {
    var W = 560, H = 560, M = 40;
    var pts = [];
    model.drones.forEach(function (d) { pts.push([d.home[1], d.home[0]]); });
    model.legs.forEach(function (l) { pts.push([l.from[1], l.from[0]], [l.to[1], l.to[0]]); });
    if (model.airspace.fence) model.airspace.fence.forEach(function (v) { pts.push([v[1], v[0]]); });
    model.findings.forEach(function (f) {
      if (f.closest) f.closest.forEach(function (p) { pts.push([p[1], p[0]]); });
    });
    var b = bounds(pts, 10);
    var span = Math.max(b.hi[0] - b.lo[0], b.hi[1] - b.lo[1]);
    var s = (W - 2 * M) / span;
    var cx = (b.lo[0] + b.hi[0]) / 2, cy = (b.lo[1] + b.hi[1]) / 2;
    // [north, east] in metres to the page.
    function at(p) { return [W / 2 + (p[1] - cx) * s, H / 2 - (p[0] - cy) * s]; }
    var root = svg("svg", { id: "plan", viewBox: "0 0 " + W + " " + H, "class": "view" }, parent);
    svg("title", {}, root, "plan view: from above, north up, metres");
    grid(root, W, H, M, s, cx, cy, span, model.origin);
    var f = model.airspace.fence;
    if (f) {
      svg("polygon", {
        "class": "fence",
        points: f.map(function (v) { return at(v).join(","); }).join(" ")
      }, root);
    }
    var legs = svg("g", { "class": "legs" }, root);
    model.legs.forEach(function (l) { drawLeg(legs, l, model, at, "leg"); });
    model.drones.forEach(function (d, i) {
      var p = at(d.home);
      var g = svg("g", { "class": "home", "data-drone": i }, root);
      svg("rect", { x: p[0] - 5, y: p[1] - 5, width: 10, height: 10, fill: d.colour }, g);
      svg("text", { x: p[0] + 8, y: p[1] + 16 }, g, d.name);
    });
    drawFindings(root, model, at);
    svg("g", { "class": "live" }, root);
    return { svg: root, at: at };
  }

  function grid(root, W, H, M, s, cx, cy, span, origin) {
    var g = svg("g", { "class": "grid" }, root);
    var step = niceStep(span, 8);
    var e0 = Math.ceil((cx - (W / 2) / s) / step) * step;
    for (var e = e0; W / 2 + (e - cx) * s < W; e += step) {
      var x = W / 2 + (e - cx) * s;
      svg("line", { x1: x, y1: 0, x2: x, y2: H }, g);
      svg("text", { x: x + 2, y: H - 4 }, g, fmt(e));
    }
    var n0 = Math.ceil((cy - (H / 2) / s) / step) * step;
    for (var n = n0; H / 2 - (n - cy) * s > 0; n += step) {
      var y = H / 2 - (n - cy) * s;
      svg("line", { x1: 0, y1: y, x2: W, y2: y }, g);
      svg("text", { x: 2, y: y - 2 }, g, fmt(n));
    }
    var where = origin
      ? "origin " + origin.lat.toFixed(6) + ", " + origin.lon.toFixed(6)
      : "fleet frame";
    svg("rect", { x: 0, y: 0, width: W, height: 22, "class": "caption-bg" }, root);
    svg("text", { x: 8, y: 16, "class": "caption" }, root,
      "N ↑  E →  grid " + fmt(step) + " m, " + where);
  }

  function drawLeg(parent, l, model, at, cls) {
    var d = model.drones[l.drone] || { colour: "#000", name: "?" };
    var a = at(l.from), b = at(l.to);
    var link = svg("a", { href: lineLink(l.line) }, parent);
    var e;
    if (l.boxed) {
      e = svg("rect", {
        "class": cls + " boxed", "data-drone": l.drone, "data-line": l.line, stroke: d.colour, fill: d.colour,
        x: Math.min(a[0], b[0]), y: Math.min(a[1], b[1]),
        width: Math.abs(b[0] - a[0]), height: Math.abs(b[1] - a[1])
      }, link);
    } else {
      e = svg("line", {
        "class": cls, "data-drone": l.drone, "data-line": l.line, stroke: d.colour,
        x1: a[0], y1: a[1], x2: b[0], y2: b[1]
      }, link);
      svg("circle", { "class": cls + "-end", cx: b[0], cy: b[1], r: 2.5, fill: d.colour }, link);
    }
    var round = l.rounds && l.rounds.length
      ? ", round " + l.rounds.map(function (r) { return r + 1; }).join(".") : "";
    svg("title", {}, e, (l.action || d.name) + (l.line ? " (line " + l.line + round + ")" : ""));
    return e;
  }

  function drawFindings(root, model, at) {
    var g = svg("g", { "class": "findings" }, root);
    model.findings.forEach(function (f, n) {
      if (!f.legs.length && !f.closest) return;
      f.legs.forEach(function (l) { drawLeg(g, l, model, at, "finding-leg"); });
      if (!f.closest) return;
      var p = at(f.closest[0]), q = at(f.closest[1]);
      // Two drones' closest points, or where one leg leaves the airspace.
      var breach = f.kind !== "too-close";
      var mark = svg("g", { "class": breach ? "finding-breach" : "finding-closest", "data-finding": n }, g);
      svg("title", {}, mark, (n + 1) + ". " + f.message);
      if (!breach) svg("line", { x1: p[0], y1: p[1], x2: q[0], y2: q[1] }, mark);
      svg("circle", { cx: p[0], cy: p[1], r: 7 }, mark);
      if (!breach) svg("circle", { cx: q[0], cy: q[1], r: 7 }, mark);
      svg("text", { x: p[0] + 10, y: p[1] - 10 }, mark, String(n + 1));
    });
  }

  // ---- side view: from the south, east to the right (under the plan
  // view's own east axis), height up ------------------------------------
  function sideView(parent, model) {
    var W = 560, H = 260, M = 30;
    var pts = [];
    model.drones.forEach(function (d) { pts.push([d.home[1], 0]); });
    model.legs.forEach(function (l) { pts.push([l.from[1], l.from[2]], [l.to[1], l.to[2]]); });
    var a = model.airspace;
    if (a.ceiling !== null) pts.push([pts.length ? pts[0][0] : 0, a.ceiling]);
    var b = bounds(pts, 6);
    var sx = (W - 2 * M) / (b.hi[0] - b.lo[0]);
    var top = Math.max(b.hi[1], 1), sz = (H - 2 * M) / (top - Math.min(0, b.lo[1]));
    var ground = H - M + Math.min(0, b.lo[1]) * sz;
    function at(p) { return [M + (p[1] - b.lo[0]) * sx, ground - p[2] * sz]; }
    var root = svg("svg", { id: "side", viewBox: "0 0 " + W + " " + H, "class": "view" }, parent);
    svg("title", {}, root, "side view: from the south, east to the right, height up");
    var g = svg("g", { "class": "grid" }, root);
    var step = niceStep(top, 5);
    for (var z = 0; z <= top; z += step) {
      var y = ground - z * sz;
      svg("line", { x1: 0, y1: y, x2: W, y2: y }, g);
      svg("text", { x: 2, y: y - 2 }, g, fmt(z) + " m");
    }
    svg("line", { "class": "ground", x1: 0, y1: ground, x2: W, y2: ground }, root);
    if (a.ceiling !== null) {
      var c = ground - a.ceiling * sz;
      svg("line", { "class": "ceiling", x1: 0, y1: c, x2: W, y2: c }, root);
      svg("text", { "class": "caption", x: W - 90, y: c - 4 }, root, "ceiling " + fmt(a.ceiling) + " m");
    }
    if (a.floor > 0) {
      var fl = ground - a.floor * sz;
      svg("line", { "class": "floor", x1: 0, y1: fl, x2: W, y2: fl }, root);
    }
    if (a.fence) {
      var ys = a.fence.map(function (v) { return v[1]; });
      [Math.min.apply(null, ys), Math.max.apply(null, ys)].forEach(function (y) {
        var px = at([0, y, 0])[0];
        svg("line", { "class": "fence-side", x1: px, y1: 0, x2: px, y2: ground }, root);
      });
    }
    var legs = svg("g", { "class": "legs" }, root);
    model.legs.forEach(function (l) { drawLeg(legs, l, model, at, "leg"); });
    model.drones.forEach(function (d, i) {
      var p = at([d.home[0], d.home[1], 0]);
      svg("rect", { "class": "home", "data-drone": i, x: p[0] - 4, y: p[1] - 4, width: 8, height: 8, fill: d.colour }, root);
    });
    drawFindings(root, model, at);
    svg("rect", { x: 0, y: 0, width: W, height: 22, "class": "caption-bg" }, root);
    svg("text", { x: 8, y: 16, "class": "caption" }, root, "seen from the south: E →, height ↑");
    svg("g", { "class": "live" }, root);
    return { svg: root, at: at };
  }

  // ---- timeline: one lane per drone ----------------------------------
  function timelineView(parent, model) {
    var t = model.timeline, LANE = 34, LEFT = 90, W = 1100, TOP = 24;
    var H = TOP + LANE * t.lanes.length + 24;
    var s = (W - LEFT - 20) / Math.max(t.length, 1);
    var root = svg("svg", { id: "timeline", viewBox: "0 0 " + W + " " + H, "class": "view" }, parent);
    svg("title", {}, root, "nominal timeline, seconds");
    var defs = svg("defs", {}, root);
    var marker = svg("marker", { id: "arrow", viewBox: "0 0 10 10", refX: 9, refY: 5, markerWidth: 6, markerHeight: 6, orient: "auto" }, defs);
    svg("path", { d: "M0,0 L10,5 L0,10 z" }, marker);
    function x(time) { return LEFT + time * s; }
    function y(lane) { return TOP + lane * LANE; }
    var axis = svg("g", { "class": "grid" }, root);
    var step = niceStep(Math.max(t.length, 1), 10);
    for (var v = 0; v <= t.length + 1e-9; v += step) {
      svg("line", { x1: x(v), y1: TOP - 4, x2: x(v), y2: H - 20 }, axis);
      svg("text", { x: x(v) + 2, y: H - 6 }, axis, fmt(v) + " s");
    }
    t.lanes.forEach(function (lane, i) {
      var d = model.drones[lane.drone];
      var g = svg("g", { "class": "lane", "data-drone": lane.drone }, root);
      svg("text", { x: 4, y: y(i) + LANE / 2 + 4, "class": "lane-name", fill: d.colour }, g, d.name);
      lane.bars.forEach(function (bar) {
        var link = svg("a", { href: lineLink(bar.line) }, g);
        var r = svg("rect", {
          "class": "bar", "data-line": bar.line, x: x(bar.start), y: y(i) + 6,
          width: Math.max(x(bar.end) - x(bar.start), 2), height: LANE - 12, fill: d.colour
        }, link);
        svg("title", {}, r, bar.action + ": " + fmt(bar.start) + " s to " + fmt(bar.end) + " s (line " + bar.line + ")");
        if (x(bar.end) - x(bar.start) > 60) {
          svg("text", { "class": "bar-label", x: x(bar.start) + 3, y: y(i) + LANE / 2 + 4 }, link,
            bar.action.replace(/^[^.]*\./, ""));
        }
      });
    });
    var laneOf = {};
    t.lanes.forEach(function (lane, i) { laneOf[lane.drone] = i; });
    t.waits.forEach(function (w) {
      var a = laneOf[w.from_drone], b = laneOf[w.to_drone];
      var y1 = y(a) + (a < b ? LANE - 6 : 6), y2 = y(b) + (a < b ? 6 : LANE - 6);
      var p = svg("path", {
        "class": "wait", "marker-end": "url(#arrow)",
        d: "M" + x(w.from_time) + "," + y1 + " L" + x(w.to_time) + "," + y2
      }, root);
      svg("title", {}, p, "waits: " + w.label);
    });
    return { svg: root };
  }

  // ---- mission graph beside the source --------------------------------
  function graphView(parent, model) {
    var g = new dagre.graphlib.Graph();
    g.setGraph({ rankdir: "TB", nodesep: 14, ranksep: 22, marginx: 10, marginy: 10 });
    g.setDefaultEdgeLabel(function () { return {}; });
    model.graph.nodes.forEach(function (n) {
      if (n.shape === "place") g.setNode(n.id, { width: 16, height: 16, node: n });
      else g.setNode(n.id, { width: Math.min(Math.max(n.label.length * 6.2 + 12, 30), 220), height: 22, node: n });
    });
    model.graph.edges.forEach(function (e) { g.setEdge(e.from, e.to, { read: e.read }); });
    dagre.layout(g);
    var size = g.graph();
    var root = svg("svg", {
      id: "graph", "class": "view", width: size.width, height: size.height,
      viewBox: "0 0 " + size.width + " " + size.height
    }, parent);
    svg("title", {}, root, "the mission's net, coloured per drone; click a node for its line");
    var edges = svg("g", { "class": "edges" }, root);
    g.edges().forEach(function (e) {
      var pts = g.edge(e).points;
      svg("path", {
        "class": g.edge(e).read ? "arc read" : "arc", "marker-end": "url(#arrow-graph)",
        d: "M" + pts.map(function (p) { return p.x + "," + p.y; }).join(" L")
      }, edges);
    });
    var defs = svg("defs", {}, root);
    var marker = svg("marker", { id: "arrow-graph", viewBox: "0 0 10 10", refX: 10, refY: 5, markerWidth: 5, markerHeight: 5, orient: "auto" }, defs);
    svg("path", { d: "M0,0 L10,5 L0,10 z" }, marker);
    var byId = {};
    g.nodes().forEach(function (id) {
      var v = g.node(id), n = v.node;
      var colour = n.drone === null ? "#bdbdbd" : model.drones[n.drone].colour;
      var a = svg("a", {
        "class": "node " + n.shape, "data-id": n.id, "data-line": n.line,
        "data-drone": n.drone === null ? "" : n.drone, href: lineLink(n.line)
      }, root);
      if (n.shape === "place") {
        svg("circle", { cx: v.x, cy: v.y, r: 8, stroke: colour, fill: n.marked ? colour : "#fff" }, a);
      } else {
        svg("rect", { x: v.x - v.width / 2, y: v.y - v.height / 2, width: v.width, height: v.height, rx: 3, fill: colour }, a);
        svg("text", { x: v.x, y: v.y + 4 }, a, n.label.length > 34 ? n.label.slice(0, 33) + "…" : n.label);
      }
      svg("title", {}, a, n.label + " (" + n.id + (n.line ? ", line " + n.line : "") + ")");
      byId[n.id] = a;
    });
    return { svg: root, nodes: byId };
  }

  function sourceView(parent, model) {
    var pre = html("pre", { id: "source" }, parent);
    model.source.forEach(function (text, i) {
      var line = html("span", { id: "L" + (i + 1), "class": "src-line" }, pre);
      html("a", { "class": "line-no", href: "#L" + (i + 1) }, line, String(i + 1));
      line.appendChild(document.createTextNode(text + "\n"));
    });
    return pre;
  }

  function findingsList(parent, model) {
    var ol = html("ol", { id: "findings" }, parent);
    if (!model.findings.length) html("p", { "class": "none" }, parent, "eamos check found nothing.");
    model.findings.forEach(function (f) {
      var li = html("li", { "class": f.error ? "error" : "warning" }, ol);
      html("code", {}, li, f.kind);
      li.appendChild(document.createTextNode(" " + f.message + " "));
      if (f.line) html("a", { href: "#L" + f.line }, li, "line " + f.line);
    });
    if (model.plan_error) html("p", { "class": "error" }, parent, model.plan_error);
  }

  function legend(parent, model) {
    var ul = html("ul", { "class": "legend" }, parent);
    model.drones.forEach(function (d) {
      var li = html("li", {}, ul);
      html("span", { "class": "swatch", style: "background:" + d.colour }, li);
      li.appendChild(document.createTextNode(d.name));
    });
  }

  // Following a link to a line (from a node, a leg, a bar or the line's
  // own number) marks the line in the source and everything drawn from it.
  function followLines(view) {
    function mark() {
      var old = document.querySelectorAll(".here");
      for (var i = 0; i < old.length; i++) old[i].classList.remove("here");
      var id = location.hash.slice(1);
      var line = id && document.getElementById(id);
      if (!line || !line.classList.contains("src-line")) return;
      line.classList.add("here");
      var drawn = document.querySelectorAll('[data-line="' + id.slice(1) + '"]');
      for (var j = 0; j < drawn.length; j++) drawn[j].classList.add("here");
    }
    window.addEventListener("hashchange", mark);
    mark();
  }

  function render(root, model) {
    root.innerHTML = "";
    var head = html("header", {}, root);
    html("h1", {}, head, model.name);
    // The file's name alone: a report is often shared away from the disk
    // it was made on.
    var file = model.file.split(/[\\/]/).pop();
    html("p", { "class": "file", title: model.file }, head, file + ": " + model.drones.length +
      " drones, " + model.legs.length + " legs, nominal length " + fmt(model.timeline.length) + " s");
    legend(head, model);
    findingsList(head, model);
    var space = html("section", { id: "space-views" }, root);
    html("h2", {}, space, "Plan and side views");
    var views = html("div", { "class": "pair" }, space);
    var plan = planView(html("figure", {}, views), model);
    var side = sideView(html("figure", {}, views), model);
    var tl = html("section", { id: "timeline-view" }, root);
    html("h2", {}, tl, "Timeline (nominal durations)");
    var timeline = timelineView(tl, model);
    var gs = html("section", { id: "graph-view" }, root);
    html("h2", {}, gs, "Mission graph and source");
    var both = html("div", { "class": "graph-and-source" }, gs);
    var graph = graphView(html("div", { "class": "graph-box" }, both), model);
    sourceView(html("div", { "class": "source-box" }, both), model);
    var view = { model: model, plan: plan, side: side, timeline: timeline, graph: graph };
    view.update = function (event) { update(view, event); };
    followLines(view);
    return view;
  }

  // Live changes, for a monitor: see the top of this file.
  // A drone's index in the model, by name (a live page looks it up for
  // every sample: a hundred drones send a thousand a second).
  function droneIndex(view, name) {
    if (!view.index) {
      view.index = {};
      view.model.drones.forEach(function (d, i) { view.index[d.name] = i; });
    }
    var i = view.index[name];
    return i === undefined ? -1 : i;
  }

  function update(view, event) {
    var model = view.model;
    var i = droneIndex(view, event.drone);
    if (event.event === "telemetry" && i >= 0 && event.position) {
      // The fleet frame, as the homes and legs are drawn.
      var p = event.position, at = [p.x, p.y, p.z];
      [view.plan, view.side].forEach(function (v) {
        v.dots = v.dots || {};
        var dot = v.dots[i];
        if (!dot) {
          dot = v.dots[i] = svg("circle", { "class": "live-drone", "data-drone": i, r: 6, fill: model.drones[i].colour },
            v.svg.querySelector("g.live"));
        }
        var q = v.at(at);
        dot.setAttribute("cx", q[0]);
        dot.setAttribute("cy", q[1]);
      });
    } else if (event.event === "marking") {
      // Each peer says what it holds; the net's marking is all of them. A
      // place is marked while some peer holds it: only the places this
      // peer took or gave up change, so that a hundred drones' markings
      // do not restyle the whole graph each time.
      view.marking = view.marking || {};
      view.holders = view.holders || {};
      var before = view.marking[event.drone] || [], after = event.marked || [];
      view.marking[event.drone] = after;
      var held = function (id, by) {
        view.holders[id] = (view.holders[id] || 0) + by;
        var node = view.graph.nodes[id];
        if (node) node.classList.toggle("marked", view.holders[id] > 0);
      };
      var was = {}, is = {};
      before.forEach(function (id) { was[id] = true; });
      after.forEach(function (id) { is[id] = true; });
      before.forEach(function (id) { if (!is[id]) held(id, -1); });
      after.forEach(function (id) { if (!was[id]) held(id, 1); });
    }
  }

  return { render: render, update: update, droneIndex: droneIndex };
})();
