// signorini HTML player: draws a recorded run with three.js (the global THREE), from the JSON in
// #signorini-data (written by signorini/player.py, which documents every field). Frames are drawn
// only when something changed, so a still page renders the same pixels every time.
(function () {
  "use strict";
  var D = JSON.parse(document.getElementById("signorini-data").textContent);

  // base64 little-endian arrays from the page data
  function bytes(b64) {
    var s = atob(b64), out = new Uint8Array(s.length);
    for (var i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
    return out.buffer;
  }
  function f32(b64) { return new Float32Array(bytes(b64)); }
  function u32(b64) { return new Uint32Array(bytes(b64)); }
  function u8(b64) { return new Uint8Array(bytes(b64)); }
  // the first index of a sorted array whose value is >= x (the length when none is)
  function lowerBound(a, x) {
    var lo = 0, hi = a.length;
    while (lo < hi) { var mid = (lo + hi) >> 1; if (a[mid] < x) lo = mid + 1; else hi = mid; }
    return lo;
  }

  var N = D.names.length, F = D.frames;
  var time = f32(D.time), pos = f32(D.pos), quat = f32(D.quat), vel = f32(D.vel);
  var targets = f32(D.camera.targets);
  var contacts = null;
  if (D.contacts) {
    contacts = { offsets: u32(D.contacts.offsets), point: f32(D.contacts.point),
                 normal: f32(D.contacts.normal), force: f32(D.contacts.force) };
  }
  // contact events of every kind, by step (so by frame too); none in records written before them
  var events = null, E = 0;
  if (D.events) {
    events = { kind: u8(D.events.kind), step: u32(D.events.step), frame: u32(D.events.frame),
               a: u32(D.events.a), b: u32(D.events.b), point: f32(D.events.point), normal: f32(D.events.normal),
               speed: f32(D.events.speed), impulse: f32(D.events.impulse) };
    E = events.kind.length;
  }

  // renderer, scene, camera, lights
  var view = document.getElementById("view");
  var renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setClearColor(0xffffff, 1);
  view.appendChild(renderer.domElement);
  var scene = new THREE.Scene();
  var up = new THREE.Vector3().fromArray(D.camera.up);
  var camera = new THREE.PerspectiveCamera(D.camera.fov, 1, 1e-3, 1e4);
  camera.up.copy(up);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x666666, 0.55));
  var sun = new THREE.DirectionalLight(0xffffff, 0.6);
  camera.add(sun);
  sun.position.set(0.3, 0.6, 1.0);
  scene.add(camera);

  // bodies: flat-shaded meshes (non-indexed, so every triangle has its own normal)
  var bodies = [];
  D.meshes.forEach(function (m, i) {
    var v = f32(m.v), f = u32(m.f);
    var flat = new Float32Array(f.length * 3);
    for (var k = 0; k < f.length; k++) {
      flat[3 * k] = v[3 * f[k]]; flat[3 * k + 1] = v[3 * f[k] + 1]; flat[3 * k + 2] = v[3 * f[k] + 2];
    }
    var g = new THREE.BufferGeometry();
    g.addAttribute("position", new THREE.BufferAttribute(flat, 3));
    g.computeVertexNormals();
    g.computeBoundingBox();
    var material = new THREE.MeshLambertMaterial({
      color: D.colours[i], side: D["static"][i] ? THREE.DoubleSide : THREE.FrontSide,
      transparent: D["static"][i], opacity: D["static"][i] ? 0.8 : 1.0,
      polygonOffset: D["static"][i], polygonOffsetFactor: 1, polygonOffsetUnits: 1
    });
    var mesh = new THREE.Mesh(g, material);
    mesh.name = D.names[i];
    if (D["static"][i]) {
      // scenery gets its triangle edges drawn, so sliding over it shows
      var edges = new THREE.LineSegments(new THREE.WireframeGeometry(g),
        new THREE.LineBasicMaterial({ color: 0x999999, transparent: true, opacity: 0.5 }));
      mesh.add(edges);
    }
    scene.add(mesh);
    bodies.push(mesh);
  });

  // contacts: points, normals and force arrows, with room for the largest frame
  var maxK = 1;
  if (contacts) for (var q = 0; q < F; q++) maxK = Math.max(maxK, contacts.offsets[q + 1] - contacts.offsets[q]);
  function buffer(count) {
    var g = new THREE.BufferGeometry();
    g.addAttribute("position", new THREE.BufferAttribute(new Float32Array(count * 3), 3));
    g.setDrawRange(0, 0);
    return g;
  }
  var points = new THREE.Points(buffer(maxK), new THREE.PointsMaterial({ color: 0x000000, size: 6, sizeAttenuation: false, depthTest: false }));
  var normals = new THREE.LineSegments(buffer(2 * maxK), new THREE.LineBasicMaterial({ color: 0x0077ff, depthTest: false }));
  var forces = new THREE.LineSegments(buffer(2 * maxK), new THREE.LineBasicMaterial({ color: 0xd00000, depthTest: false }));
  var heads = new THREE.LineSegments(buffer(4 * maxK), new THREE.LineBasicMaterial({ color: 0xd00000, depthTest: false }));
  [points, normals, forces, heads].forEach(function (o) { o.frustumCulled = false; o.renderOrder = 10; scene.add(o); });

  // event markers: a cross of 3 strokes at each point and a hit's normal, 8 vertices an event,
  // coloured by kind and faded towards the white background; the buffer grows to the most shown
  function markBuffer(count) {
    var g = buffer(8 * count);
    g.addAttribute("color", new THREE.BufferAttribute(new Float32Array(24 * count), 3));
    return g;
  }
  var marks = new THREE.LineSegments(markBuffer(1), new THREE.LineBasicMaterial({ vertexColors: THREE.VertexColors, depthTest: false }));
  marks.frustumCulled = false; marks.renderOrder = 11; scene.add(marks);
  var kindColours = events ? D.events.colours.map(function (c) { return new THREE.Color(c); }) : [];
  function markRoom(count) {
    if (marks.geometry.attributes.position.count >= 8 * count) return;
    marks.geometry.dispose();
    marks.geometry = markBuffer(count);
  }

  // the user interface
  var ui = {
    play: document.getElementById("play"), timeline: document.getElementById("timeline"),
    clock: document.getElementById("clock"), speed: document.getElementById("speed"),
    contacts: document.getElementById("show-contacts"), normals: document.getElementById("show-normals"),
    forces: document.getElementById("show-forces"), follow: document.getElementById("follow"),
    info: document.getElementById("info"), events: document.getElementById("show-events"),
    eventList: document.getElementById("event-list"), ticks: document.getElementById("ticks")
  };
  ui.timeline.max = String(F - 1);
  ui.follow.checked = !!D.camera.follow;
  // the event controls only for a record with events: one without plays as it always did
  document.getElementById("events-toggle").hidden = ui.ticks.hidden = !events;
  var state = { frame: 0, playing: false, clock: time[0], last: null, dirty: true, selected: -1, marks: [] };

  // orbit camera: spherical coordinates about the target, in a frame whose pole is 'up'
  var offset = new THREE.Vector3().fromArray(D.camera.offset);
  var orbit = { distance: offset.length(), pan: new THREE.Vector3() };
  var e1 = new THREE.Vector3().copy(offset).projectOnPlane(up);
  if (e1.lengthSq() < 1e-12) e1.set(1, 0, 0).projectOnPlane(up);
  e1.normalize();
  var e2 = new THREE.Vector3().crossVectors(up, e1);
  orbit.azimuth = 0;
  orbit.elevation = Math.asin(Math.max(-1, Math.min(1, offset.dot(up) / orbit.distance)));
  var fixedTarget = new THREE.Vector3(targets[0], targets[1], targets[2]);

  function placeCamera() {
    var f = state.frame;
    var target = ui.follow.checked ? new THREE.Vector3(targets[3 * f], targets[3 * f + 1], targets[3 * f + 2])
                                   : fixedTarget.clone();
    target.add(orbit.pan);
    var c = Math.cos(orbit.elevation), s = Math.sin(orbit.elevation);
    var dir = new THREE.Vector3()
      .addScaledVector(e1, c * Math.cos(orbit.azimuth))
      .addScaledVector(e2, c * Math.sin(orbit.azimuth))
      .addScaledVector(up, s);
    camera.position.copy(target).addScaledVector(dir, orbit.distance);
    camera.near = orbit.distance / 1000; camera.far = orbit.distance * 1000;
    camera.lookAt(target);
    camera.updateProjectionMatrix();
  }

  function resize() {
    var w = view.clientWidth, h = view.clientHeight;
    renderer.setSize(w, h);
    camera.aspect = w / Math.max(h, 1);
    state.dirty = true;
  }
  window.addEventListener("resize", resize);

  // the timeline's ticks: one per kind at each frame with events, in rows (hits on top, beginnings,
  // ends), where the slider's thumb stands at that frame (the thumb's travel is inset by half its
  // width, 8 px in Chromium); drawn again whenever the slider moved or changed width
  var THUMB = 8, ROW = 4, ROWS = [1, 2, 0, 1, 2];
  var ticks = { list: [], at: "" };
  function drawTicks() {
    if (!events) return;
    var c = ui.ticks, r = c.getBoundingClientRect(), t = ui.timeline.getBoundingClientRect();
    var at = [r.left, r.top, r.width, t.left, t.width].join();
    if (at === ticks.at) return;
    ticks.at = at;
    ticks.list = [];
    var ratio = window.devicePixelRatio || 1;
    c.width = Math.round(r.width * ratio); c.height = Math.round(r.height * ratio);
    var g = c.getContext("2d");
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.clearRect(0, 0, r.width, r.height);
    var last = [-1, -1, -1, -1, -1];
    for (var e = 0; e < E; e++) {
      var k = events.kind[e], f = events.frame[e];
      if (last[k] === f) continue;
      last[k] = f;
      var x = Math.round(t.left - r.left + THUMB + (t.width - 2 * THUMB) * (F > 1 ? f / (F - 1) : 0));
      g.fillStyle = D.events.colours[k];
      g.fillRect(x - 1, ROWS[k] * ROW, 2, ROW);
      ticks.list.push({ frame: f, kind: D.events.kinds[k], x: r.left + x, y: r.top + (ROWS[k] + 0.5) * ROW });
    }
  }

  // pose the bodies and the contacts at frame f
  function show(f) {
    for (var i = 0; i < N; i++) {
      var p = 3 * (f * N + i), r = 4 * (f * N + i);
      bodies[i].position.set(pos[p], pos[p + 1], pos[p + 2]);
      bodies[i].quaternion.set(quat[r + 1], quat[r + 2], quat[r + 3], quat[r]);
    }
    var lo = 0, hi = 0;
    if (contacts) { lo = contacts.offsets[f]; hi = contacts.offsets[f + 1]; }
    var K = hi - lo;
    var P = points.geometry.attributes.position.array, L = normals.geometry.attributes.position.array;
    var A = forces.geometry.attributes.position.array, H = heads.geometry.attributes.position.array;
    var tip = new THREE.Vector3(), base = new THREE.Vector3(), dir = new THREE.Vector3(), side = new THREE.Vector3();
    for (var k = 0; k < K; k++) {
      var j = 3 * (lo + k);
      for (var a = 0; a < 3; a++) {
        P[3 * k + a] = contacts.point[j + a];
        L[6 * k + a] = contacts.point[j + a];
        L[6 * k + 3 + a] = contacts.point[j + a] + D.normal_length * contacts.normal[j + a];
        A[6 * k + a] = contacts.point[j + a];
        A[6 * k + 3 + a] = contacts.point[j + a] + D.force_scale * contacts.force[j + a];
      }
      // an arrow head: two short strokes back from the tip
      base.set(A[6 * k], A[6 * k + 1], A[6 * k + 2]);
      tip.set(A[6 * k + 3], A[6 * k + 4], A[6 * k + 5]);
      dir.subVectors(tip, base);
      var len = dir.length();
      side.crossVectors(dir, camera.position.clone().sub(tip));
      if (side.lengthSq() > 0) side.setLength(0.12 * len);
      dir.multiplyScalar(0.25);
      var h1 = tip.clone().sub(dir).add(side), h2 = tip.clone().sub(dir).sub(side);
      H.set([tip.x, tip.y, tip.z, h1.x, h1.y, h1.z, tip.x, tip.y, tip.z, h2.x, h2.y, h2.z], 12 * k);
    }
    points.geometry.setDrawRange(0, K);
    normals.geometry.setDrawRange(0, 2 * K);
    forces.geometry.setDrawRange(0, 2 * K);
    heads.geometry.setDrawRange(0, 4 * K);
    [points, normals, forces, heads].forEach(function (o) { o.geometry.attributes.position.needsUpdate = true; });
    points.visible = ui.contacts.checked;
    normals.visible = ui.normals.checked;
    forces.visible = heads.visible = ui.forces.checked && D.force_scale > 0;

    ui.timeline.value = String(f);
    ui.clock.textContent = "t = " + time[f].toFixed(3) + " s  (" + (f + 1) + "/" + F + ")";
    showInfo(f, K);
    showEvents(f);
    drawTicks();
  }

  function showInfo(f, K) {
    var lines = [K + " contact" + (K === 1 ? "" : "s")];
    var i = state.selected;
    if (i >= 0) {
      var p = 3 * (f * N + i);
      lines.push(D.names[i] + (D["static"][i] ? " (static)" : " m = " + D.masses[i].toPrecision(4) + " kg"));
      lines.push("x = " + [pos[p], pos[p + 1], pos[p + 2]].map(function (x) { return x.toFixed(4); }).join(", ") + " m");
      lines.push("v = " + [vel[p], vel[p + 1], vel[p + 2]].map(function (x) { return x.toFixed(4); }).join(", ") + " m/s");
    }
    ui.info.textContent = lines.join("\n");
  }

  // the events of frame f and of the frames event_fade s before it: their crosses, fading with
  // the time since, and the list of frame f's own
  function showEvents(f) {
    state.marks = [];
    var list = ui.eventList;
    while (list.firstChild) list.removeChild(list.firstChild);
    marks.visible = !!events && ui.events.checked;
    if (!marks.visible) return;
    var g = lowerBound(time, time[f] - D.event_fade);
    while (g <= f && time[f] - time[g] >= D.event_fade) g++;
    var lo = lowerBound(events.frame, g), hi = lowerBound(events.frame, f + 1);
    markRoom(hi - lo);
    var P = marks.geometry.attributes.position.array, C = marks.geometry.attributes.color.array;
    var white = new THREE.Color(1, 1, 1);
    for (var n = 0, e = lo; e < hi; n++, e++) {
      var k = events.kind[e], hit = D.events.kinds[k] === "hit";
      var at = new THREE.Vector3().fromArray(events.point, 3 * e), normal = new THREE.Vector3().fromArray(events.normal, 3 * e);
      var alpha = 1 - (time[f] - time[events.frame[e]]) / D.event_fade;
      var half = (hit ? 0.5 : 0.3) * D.normal_length;
      // three strokes along the axes, then the normal (a point where there is none)
      for (var a = 0; a < 3; a++) {
        var stroke = new THREE.Vector3().setComponent(a, half);
        at.clone().sub(stroke).toArray(P, 24 * n + 6 * a);
        at.clone().add(stroke).toArray(P, 24 * n + 6 * a + 3);
      }
      at.toArray(P, 24 * n + 18);
      at.clone().addScaledVector(normal, hit ? D.normal_length : 0).toArray(P, 24 * n + 21);
      var colour = kindColours[k].clone().lerp(white, 1 - alpha);
      for (var v = 0; v < 8; v++) colour.toArray(C, 24 * n + 3 * v);
      state.marks.push({ index: e, kind: D.events.kinds[k], step: events.step[e], frame: events.frame[e],
                         a: events.a[e], b: events.b[e], point: at.toArray(), alpha: alpha });
    }
    marks.geometry.setDrawRange(0, 8 * n);
    marks.geometry.attributes.position.needsUpdate = marks.geometry.attributes.color.needsUpdate = true;

    // the list: kind, the two bodies and a hit's speed and impulse, at most 8 lines
    var first = lowerBound(events.frame, f);
    for (e = first; e < Math.min(hi, first + 8); e++) {
      k = events.kind[e];
      var label = D.events.kinds[k], line = document.createElement("div"), swatch = document.createElement("span");
      swatch.textContent = "\u25a0 ";
      swatch.style.color = D.events.colours[k];
      var text = (label + "            ").slice(0, 13) + D.names[events.a[e]] + " / " + D.names[events.b[e]];
      if (label === "hit") text += "  " + events.speed[e].toFixed(2) + " m/s  " + events.impulse[e].toPrecision(3) + " N s";
      line.appendChild(swatch);
      line.appendChild(document.createTextNode(text));
      list.appendChild(line);
    }
    if (hi - first > 8) {
      var more = document.createElement("div");
      more.textContent = "  and " + (hi - first - 8) + " more";
      list.appendChild(more);
    }
  }

  // the next (dir 1) or previous (dir -1) frame with events; this one when there is none
  function eventFrame(dir) {
    if (!E) return state.frame;
    if (dir > 0) { var i = lowerBound(events.frame, state.frame + 1); return i < E ? events.frame[i] : state.frame; }
    var j = lowerBound(events.frame, state.frame);
    return j > 0 ? events.frame[j - 1] : state.frame;
  }

  function seek(f) {
    state.frame = Math.max(0, Math.min(F - 1, Math.round(f)));
    state.clock = time[state.frame];
    state.dirty = true;
  }
  function setPlaying(on) {
    state.playing = on && F > 1;
    if (state.playing && state.frame >= F - 1) seek(0);
    state.last = null;
    ui.play.textContent = state.playing ? "pause" : "play";
  }

  ui.play.addEventListener("click", function () { setPlaying(!state.playing); });
  ui.timeline.addEventListener("input", function () { setPlaying(false); seek(Number(ui.timeline.value)); });
  [ui.contacts, ui.normals, ui.forces, ui.follow, ui.events].forEach(function (el) {
    el.addEventListener("change", function () { state.dirty = true; });
  });
  window.addEventListener("keydown", function (e) {
    if (e.target && e.target.tagName === "SELECT") return;
    if (e.key === " ") { setPlaying(!state.playing); e.preventDefault(); }
    else if (e.key === "ArrowRight") { setPlaying(false); seek(state.frame + 1); e.preventDefault(); }
    else if (e.key === "ArrowLeft") { setPlaying(false); seek(state.frame - 1); e.preventDefault(); }
    else if (e.key === "Home") { setPlaying(false); seek(0); }
    else if (e.key === "End") { setPlaying(false); seek(F - 1); }
    else if (e.key === "]" || e.key === "PageDown") { setPlaying(false); seek(eventFrame(1)); e.preventDefault(); }
    else if (e.key === "[" || e.key === "PageUp") { setPlaying(false); seek(eventFrame(-1)); e.preventDefault(); }
  });

  // mouse: drag orbits, right or shift drag pans, wheel zooms, a click picks a body
  var drag = null;
  var canvas = renderer.domElement;
  canvas.addEventListener("contextmenu", function (e) { e.preventDefault(); });
  canvas.addEventListener("pointerdown", function (e) {
    drag = { x: e.clientX, y: e.clientY, x0: e.clientX, y0: e.clientY, pan: e.button === 2 || e.shiftKey };
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    if (drag.pan) {
      var scale = orbit.distance * 2 * Math.tan(camera.fov * Math.PI / 360) / Math.max(view.clientHeight, 1);
      var right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
      var upv = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
      orbit.pan.addScaledVector(right, -dx * scale).addScaledVector(upv, dy * scale);
    } else {
      orbit.azimuth -= dx * 0.008;
      orbit.elevation = Math.max(-1.5, Math.min(1.5, orbit.elevation + dy * 0.008));
    }
    state.dirty = true;
  });
  canvas.addEventListener("pointerup", function (e) {
    if (drag && Math.abs(e.clientX - drag.x0) + Math.abs(e.clientY - drag.y0) < 4) pick(e);
    drag = null;
  });
  canvas.addEventListener("wheel", function (e) {
    orbit.distance *= Math.exp(0.001 * e.deltaY);
    state.dirty = true;
    e.preventDefault();
  }, { passive: false });

  var raycaster = new THREE.Raycaster();
  function pick(e) {
    var rect = canvas.getBoundingClientRect();
    var m = new THREE.Vector2(((e.clientX - rect.left) / rect.width) * 2 - 1, -((e.clientY - rect.top) / rect.height) * 2 + 1);
    raycaster.setFromCamera(m, camera);
    var hit = raycaster.intersectObjects(bodies, false);
    state.selected = hit.length ? bodies.indexOf(hit[0].object) : -1;
    state.dirty = true;
  }

  // the event markers drawn at the current frame, each with where its point is on the page (CSS pixels)
  function markers() {
    var rect = canvas.getBoundingClientRect();
    return state.marks.map(function (m) {
      var p = new THREE.Vector3().fromArray(m.point).project(camera), out = {};
      for (var key in m) out[key] = m[key];
      out.x = rect.left + (p.x + 1) / 2 * rect.width;
      out.y = rect.top + (1 - p.y) / 2 * rect.height;
      return out;
    });
  }

  // projected bounding rectangle of body i at the current frame, CSS pixels of the page
  function screenBox(i) {
    var b = bodies[i].geometry.boundingBox, rect = canvas.getBoundingClientRect();
    var out = { left: Infinity, top: Infinity, right: -Infinity, bottom: -Infinity };
    bodies[i].updateMatrixWorld(true);
    for (var k = 0; k < 8; k++) {
      var p = new THREE.Vector3(k & 1 ? b.max.x : b.min.x, k & 2 ? b.max.y : b.min.y, k & 4 ? b.max.z : b.min.z);
      p.applyMatrix4(bodies[i].matrixWorld).project(camera);
      var x = rect.left + (p.x + 1) / 2 * rect.width, y = rect.top + (1 - p.y) / 2 * rect.height;
      out.left = Math.min(out.left, x); out.right = Math.max(out.right, x);
      out.top = Math.min(out.top, y); out.bottom = Math.max(out.bottom, y);
    }
    return out;
  }

  // the loop: advance the clock while playing, draw when something changed
  function tick(now) {
    if (state.playing) {
      if (state.last !== null) {
        state.clock += (now - state.last) / 1000 * Number(ui.speed.value);
        var f = state.frame;
        while (f < F - 1 && time[f + 1] <= state.clock) f++;
        if (f !== state.frame) { state.frame = f; state.dirty = true; }
        if (f >= F - 1) setPlaying(false);
      }
      state.last = now;
    }
    if (state.dirty) {
      placeCamera();
      show(state.frame);
      renderer.render(scene, camera);
      state.dirty = false;
      api.rendered++;
    }
    requestAnimationFrame(tick);
  }

  var api = {
    frames: F, rendered: 0, ready: false,
    seek: function (f) { setPlaying(false); seek(f); },
    play: function () { setPlaying(true); }, pause: function () { setPlaying(false); },
    screenBox: screenBox, events: E,
    ticks: function () { return ticks.list.slice(); },
    markers: markers,
    get frame() { return state.frame; }, get dirty() { return state.dirty; }
  };
  window.signoriniPlayer = api;
  resize();
  setPlaying(false);
  requestAnimationFrame(tick);
  api.ready = true;
})();
