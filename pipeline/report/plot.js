// microslip report: the interactive FRF plots of a page, in plain JavaScript (no library, no
// network: the page opens offline). Each <div class="ms-plot"> holds its data as JSON in a
// <script type="application/json"> child (report/interactive.py). Pointing at a computed
// point shows its numbers and, where the run stored them, each contact's hysteresis loop
// there; the legend's boxes hide and show curves; dragging a box zooms in,
// a double click or the button zooms back out; a map point's letter leads to its contact
// maps. Without JavaScript the page keeps its pictures and tables: this only adds to them.
(function () {
  "use strict";
  var NS = "http://www.w3.org/2000/svg";
  var COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b",
                 "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];
  var H = 430, M = {l: 70, r: 18, t: 30, b: 50};

  function svg(tag, attrs, parent) {
    var e = document.createElementNS(NS, tag);
    Object.keys(attrs).forEach(function (k) { e.setAttribute(k, attrs[k]); });
    if (parent) { parent.appendChild(e); }
    return e;
  }

  function niceTicks(lo, hi, n) {
    var span = hi - lo, step = Math.pow(10, Math.floor(Math.log10(span / n)));
    var err = span / n / step;
    step *= err >= 7.5 ? 10 : err >= 3.5 ? 5 : err >= 1.5 ? 2 : 1;
    var out = [];
    for (var v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) {
      out.push(Math.abs(v) < 1e-12 * span ? 0 : v);
    }
    return out;
  }

  function extent(data, hidden) {
    var x0 = Infinity, x1 = -Infinity, y0 = 0, y1 = -Infinity;
    data.series.forEach(function (s, k) {
      if (hidden[k]) { return; }
      s.x.forEach(function (x, i) {
        var y = s.y[i];
        if (x === null || y === null) { return; }
        x0 = Math.min(x0, x); x1 = Math.max(x1, x); y1 = Math.max(y1, y);
      });
    });
    if (!isFinite(x0)) { return {x0: 0, x1: 1, y0: 0, y1: 1}; }
    if (x1 === x0) { x1 = x0 + 1; }
    if (y1 <= y0) { y1 = y0 + 1; }
    return {x0: x0, x1: x1, y0: y0, y1: y1 * 1.05};
  }

  function fmt(v, digits) { return v === null ? "-" : Number(v.toPrecision(digits)).toString(); }

  function tipText(data, s, i) {
    var lines = [s.label, data.x + ": " + fmt(s.x[i], 7), "response: " + fmt(s.y[i], 5) + " " + data.unit];
    if (s.stable) {
      lines.push(s.stable[i] === 1 ? "stable" : s.stable[i] === 0 ? "unstable" :
                 "stability not computed");
    }
    if (s.slip) { lines.push("slipping: " + fmt(s.slip[i], 3) + " % of the period (contacts' mean)"); }
    lines.push("point " + (i + 1) + " of " + s.x.length);
    return lines;
  }

  // a contact's hysteresis loop at one point, as a small drawing for the tooltip: the
  // tangential force against the relative displacement over the period, closed
  var LW = 170, LH = 120, LM = {l: 44, r: 6, t: 16, b: 26};
  function loopPicture(data, lp, i) {
    // integers -L..L across each loop's span [lo, hi] (interactive.py's _scaled)
    function decoded(ints, lo, hi) {
      return ints.map(function (k) { return lo + (k + data.levels) * (hi - lo) / (2 * data.levels); });
    }
    var u = decoded(lp.u[i], lp.u0[i], lp.u1[i]), T = decoded(lp.T[i], lp.T0[i], lp.T1[i]);
    function range(v) {  // the values' span, a flat one widened to be drawn
      var lo = Math.min.apply(null, v), hi = Math.max.apply(null, v);
      var pad = hi > lo ? 0 : Math.max(Math.abs(hi), 1e-30);
      return [lo - pad, hi + pad];
    }
    var ur = range(u), Tr = range(T);
    var box = svg("svg", {width: LW, height: LH, viewBox: "0 0 " + LW + " " + LH,
                          "class": "ms-loop"}, null);
    function px(v) { return LM.l + (v - ur[0]) / (ur[1] - ur[0]) * (LW - LM.l - LM.r); }
    function py(v) { return LH - LM.b - (v - Tr[0]) / (Tr[1] - Tr[0]) * (LH - LM.t - LM.b); }
    svg("rect", {x: LM.l, y: LM.t, width: LW - LM.l - LM.r, height: LH - LM.t - LM.b,
                 "class": "ms-frame"}, box);
    var d = "";
    u.forEach(function (v, j) {
      d += (j ? "L" : "M") + px(v).toFixed(1) + " " + py(T[j]).toFixed(1);
    });
    svg("path", {d: d + "Z", fill: "none", stroke: "#c03020", "stroke-width": 1.4}, box);
    svg("text", {x: 2, y: 11}, box).textContent = lp.contact + ": T [N] against u";
    svg("text", {x: LM.l - 3, y: LM.t + 8, "text-anchor": "end"}, box).textContent =
      fmt(Tr[1], 3);
    svg("text", {x: LM.l - 3, y: LH - LM.b, "text-anchor": "end"}, box).textContent =
      fmt(Tr[0], 3);
    svg("text", {x: LM.l, y: LH - LM.b + 12, "text-anchor": "start"}, box).textContent =
      fmt(ur[0], 3);
    svg("text", {x: LW - LM.r, y: LH - LM.b + 12, "text-anchor": "end"}, box).textContent =
      fmt(ur[1], 3);
    svg("text", {x: (LM.l + LW - LM.r) / 2, y: LH - 3, "text-anchor": "middle"}, box)
      .textContent = "u [" + lp.unit + "]";
    return box;
  }

  function plot(div) {
    var data = JSON.parse(div.querySelector("script[type='application/json']").textContent);
    // the drawing as wide as the page's room (a phone's text stays readable), 480-760
    var W = Math.max(480, Math.min(760, div.clientWidth || 760));
    var hidden = data.series.map(function () { return false; });
    var view = extent(data, hidden);
    var box = svg("svg", {viewBox: "0 0 " + W + " " + H, "class": "ms-svg", role: "img",
                          "aria-label": data.title}, null);
    div.appendChild(box);
    var tip = document.createElement("div");
    tip.className = "ms-tip";
    div.appendChild(tip);
    var bar = document.createElement("div");
    bar.className = "ms-legend";
    div.appendChild(bar);

    function sx(x) { return M.l + (x - view.x0) / (view.x1 - view.x0) * (W - M.l - M.r); }
    function sy(y) { return H - M.b - (y - view.y0) / (view.y1 - view.y0) * (H - M.t - M.b); }
    function ix(px) { return view.x0 + (px - M.l) / (W - M.l - M.r) * (view.x1 - view.x0); }
    function iy(py) { return view.y0 + (H - M.b - py) / (H - M.t - M.b) * (view.y1 - view.y0); }

    function axes() {
      svg("rect", {x: M.l, y: M.t, width: W - M.l - M.r, height: H - M.t - M.b,
                   "class": "ms-frame"}, box);
      niceTicks(view.x0, view.x1, 6).forEach(function (v) {
        svg("line", {x1: sx(v), x2: sx(v), y1: M.t, y2: H - M.b, "class": "ms-grid"}, box);
        svg("text", {x: sx(v), y: H - M.b + 16, "text-anchor": "middle"}, box)
          .textContent = fmt(v, 6);
      });
      niceTicks(view.y0, view.y1, 5).forEach(function (v) {
        svg("line", {x1: M.l, x2: W - M.r, y1: sy(v), y2: sy(v), "class": "ms-grid"}, box);
        svg("text", {x: M.l - 6, y: sy(v) + 4, "text-anchor": "end"}, box)
          .textContent = fmt(v, 4);
      });
      svg("text", {x: (M.l + W - M.r) / 2, y: H - 10, "text-anchor": "middle"}, box)
        .textContent = data.x;
      svg("text", {x: 16, y: (M.t + H - M.b) / 2, "text-anchor": "middle",
                   transform: "rotate(-90 16 " + (M.t + H - M.b) / 2 + ")"}, box)
        .textContent = data.y;
      svg("text", {x: M.l, y: 18, "class": "ms-title"}, box).textContent = data.title;
    }

    function line(s, colour, clip) {
      // solid between points not unstable, dashed between points not stable
      [[1, ""], [0, "6 4"]].forEach(function (style) {
        var d = "", pen = false;
        s.x.forEach(function (x, i) {
          var st = s.stable ? s.stable[i] : 1;
          var ok = x !== null && s.y[i] !== null && (style[0] === 1 ? st !== 0 : st !== 1);
          if (!ok) { pen = false; return; }
          d += (pen ? "L" : "M") + sx(x).toFixed(1) + " " + sy(s.y[i]).toFixed(1);
          pen = true;
        });
        if (d && (style[0] === 1 || s.stable)) {
          svg("path", {d: d, stroke: colour, "stroke-dasharray": style[1], fill: "none",
                       "stroke-width": s.kind === "limit" ? 1 : 1.6, "clip-path": clip}, box);
        }
      });
    }

    function points(s, k, colour) {
      s.x.forEach(function (x, i) {
        if (x === null || s.y[i] === null || x < view.x0 || x > view.x1 ||
            s.y[i] < view.y0 || s.y[i] > view.y1) { return; }
        var c = svg("circle", {cx: sx(x), cy: sy(s.y[i]), r: 3, fill: colour,
                               "fill-opacity": 0.3, "class": "ms-pt", "data-series": k,
                               "data-index": i}, box);
        c.addEventListener("mouseenter", function (ev) { show(s, i, ev); });
        c.addEventListener("mouseleave", function () { tip.style.display = "none"; });
      });
    }

    function show(s, i, ev) {
      tip.textContent = "";
      tipText(data, s, i).forEach(function (t, j) {
        var p = document.createElement(j === 0 ? "b" : "div");
        p.textContent = t;
        tip.appendChild(p);
      });
      (s.loops || []).forEach(function (lp) { tip.appendChild(loopPicture(data, lp, i)); });
      var r = div.getBoundingClientRect();
      tip.style.left = (ev.clientX - r.left + 12) + "px";
      tip.style.top = (ev.clientY - r.top + 12) + "px";
      tip.style.display = "block";
    }

    function draw() {
      while (box.firstChild) { box.removeChild(box.firstChild); }
      var id = "clip" + Math.random().toString(36).slice(2);
      var cp = svg("clipPath", {id: id}, svg("defs", {}, box));
      svg("rect", {x: M.l, y: M.t, width: W - M.l - M.r, height: H - M.t - M.b}, cp);
      axes();
      data.series.forEach(function (s, k) {
        if (hidden[k]) { return; }
        line(s, s.kind === "limit" ? "#777" : COLOURS[k % COLOURS.length], "url(#" + id + ")");
      });
      data.series.forEach(function (s, k) {
        if (!hidden[k] && s.kind === "curve") { points(s, k, COLOURS[k % COLOURS.length]); }
      });
      data.marks.forEach(function (m) {
        if (m.x < view.x0 || m.x > view.x1 || m.y < view.y0 || m.y > view.y1) { return; }
        var t = svg("text", {x: sx(m.x) + 6, y: sy(m.y) - 6, "class": "ms-mark"}, box);
        t.textContent = m.letter;
        var target = document.getElementById(m.target);
        if (target) {  // the letter leads to the point's contact maps
          t.setAttribute("class", "ms-mark ms-link");
          t.addEventListener("click", function () { target.scrollIntoView(); });
          svg("title", {}, t).textContent = "contact maps at point " + m.letter;
        }
      });
    }

    function legend() {
      data.series.forEach(function (s, k) {
        var lab = document.createElement("label");
        var box2 = document.createElement("input");
        box2.type = "checkbox";
        box2.checked = true;
        box2.addEventListener("change", function () { hidden[k] = !box2.checked; draw(); });
        var sw = document.createElement("span");
        sw.className = "ms-swatch";
        sw.style.background = s.kind === "limit" ? "#777" : COLOURS[k % COLOURS.length];
        lab.appendChild(box2);
        lab.appendChild(sw);
        lab.appendChild(document.createTextNode(s.label));
        bar.appendChild(lab);
      });
      var reset = document.createElement("button");
      reset.type = "button";
      reset.textContent = "zoom out";
      reset.addEventListener("click", function () { view = extent(data, hidden); draw(); });
      bar.appendChild(reset);
    }

    // zoom: drag a box over the plot
    var start = null, band = null;
    function local(ev) {
      var r = box.getBoundingClientRect();
      return [(ev.clientX - r.left) * W / r.width, (ev.clientY - r.top) * H / r.height];
    }
    box.addEventListener("mousedown", function (ev) {
      if (ev.target.classList && ev.target.classList.contains("ms-pt")) { return; }
      start = local(ev);
      band = svg("rect", {"class": "ms-band", x: start[0], y: start[1], width: 0, height: 0},
                 box);
    });
    box.addEventListener("mousemove", function (ev) {
      if (!start) { return; }
      var p = local(ev);
      band.setAttribute("x", Math.min(p[0], start[0]));
      band.setAttribute("y", Math.min(p[1], start[1]));
      band.setAttribute("width", Math.abs(p[0] - start[0]));
      band.setAttribute("height", Math.abs(p[1] - start[1]));
    });
    box.addEventListener("mouseup", function (ev) {
      if (!start) { return; }
      var p = local(ev);
      if (Math.abs(p[0] - start[0]) > 8 && Math.abs(p[1] - start[1]) > 8) {
        var xa = ix(Math.min(p[0], start[0])), xb = ix(Math.max(p[0], start[0]));
        var ya = iy(Math.max(p[1], start[1])), yb = iy(Math.min(p[1], start[1]));
        view = {x0: xa, x1: xb, y0: ya, y1: yb};
      }
      start = null;
      draw();
    });
    box.addEventListener("dblclick", function () { view = extent(data, hidden); draw(); });

    legend();
    draw();
  }

  document.querySelectorAll(".ms-plot").forEach(plot);
}());
