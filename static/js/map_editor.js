/*
 * The floor editor (templates/maps/editor.html): edits the site's draft map, a whole site file,
 * in the browser and saves it through the JSON API (maps/views.py). The floor is drawn with the
 * fleet page's symbols and frame (templates/robots/_floor_map.html, ui/drawing.py): metres, y
 * growing north, a margin around the floor. The server validates, compares and publishes; this
 * file only edits the document.
 */
(function () {
  "use strict";

  const root = document.getElementById("map-editor");
  if (!root) {
    return;
  }
  const SVG = "http://www.w3.org/2000/svg";
  const PAD = Number(root.dataset.margin) + 8; // the fleet page's margin, and room to add more
  const MIN_SIZE = 20;
  const svg = document.getElementById("editor-map");
  const $ = (id) => document.getElementById(id);

  let draft = null; // {revision, rollout, document}
  let floor = null; // code of the floor shown
  let selected = null; // code of the selected waypoint
  let selectedEdge = null; // the selected edge (an item of the floor's edges)
  let edgeStart = null; // first waypoint of an edge being drawn
  let dragging = false;
  let frame = null; // {minX, maxY, width, height} of the drawing
  let dirty = false;

  // --- The API ------------------------------------------------------------------------------

  async function api(url, method, body) {
    const response = await fetch(url, {
      method,
      credentials: "same-origin",
      headers: {
        Accept: "application/json",
        "Content-Type": "application/json",
        "X-CSRFToken": root.dataset.csrf,
      },
      body: body === undefined ? undefined : JSON.stringify(body),
    });
    let data = null;
    try {
      data = await response.json();
    } catch (error) {
      data = null;
    }
    return { ok: response.ok, status: response.status, data };
  }

  function say(text) {
    $("editor-status").textContent = text;
  }

  function errorsOf(data) {
    if (!data || typeof data.detail !== "object" || data.detail === null) {
      return [data && data.detail ? String(data.detail) : "the server refused it"];
    }
    if (Array.isArray(data.detail)) {
      return data.detail.map(String);
    }
    const lines = [];
    for (const [field, messages] of Object.entries(data.detail)) {
      for (const message of [].concat(messages)) {
        lines.push(typeof message === "string" ? `${field}: ${message}` : JSON.stringify(message));
      }
    }
    return lines;
  }

  function took(data) {
    draft = data;
    dirty = false;
    $("draft-revision").textContent = draft.revision;
    const floors = floorsOf();
    if (!floors.some((f) => f.code === floor)) {
      floor = floors.length ? floors[0].code : null;
    }
    if (selected && !findWaypoint(selected)) {
      selected = null;
    }
    renderAll();
  }

  async function load() {
    const answer = await api(root.dataset.draftUrl, "GET");
    if (answer.ok) {
      took(answer.data);
      say(gettext("Draft loaded."));
    } else {
      say(interpolate(gettext("Could not read the draft: %(errors)s"), { errors: errorsOf(answer.data).join("; ") }, true));
    }
  }

  async function save() {
    if (!dirty) {
      return true;
    }
    const body = { revision: draft.revision, document: draft.document };
    const answer = await api(root.dataset.draftUrl, "PUT", body);
    if (answer.ok) {
      took(answer.data);
      say(interpolate(gettext("Draft saved (revision %(revision)s)."), { revision: draft.revision }, true));
      return true;
    }
    say(interpolate(gettext("Not saved: %(errors)s"), { errors: errorsOf(answer.data).join("; ") }, true));
    return false;
  }

  function changed() {
    dirty = true;
    say(gettext("Unsaved changes."));
  }

  // --- The document -------------------------------------------------------------------------

  function floorsOf() {
    const floors = Array.isArray(draft.document.floors) ? draft.document.floors : [];
    return floors.filter((f) => f && typeof f === "object").sort((a, b) => b.level - a.level);
  }

  function floorData() {
    return floorsOf().find((f) => f.code === floor) || null;
  }

  function listOf(object, key) {
    if (!Array.isArray(object[key])) {
      object[key] = [];
    }
    return object[key];
  }

  function waypoints() {
    const f = floorData();
    return f ? listOf(f, "waypoints").filter((wp) => wp && typeof wp === "object") : [];
  }

  function edges() {
    const f = floorData();
    return f ? listOf(f, "edges") : [];
  }

  function ends(edge) {
    return Array.isArray(edge) ? [edge[0], edge[1]] : [edge && edge.from, edge && edge.to];
  }

  function resources() {
    return listOf(draft.document, "resources");
  }

  function findWaypoint(code) {
    for (const f of floorsOf()) {
      for (const wp of f.waypoints || []) {
        if (wp && wp.code === code) {
          return wp;
        }
      }
    }
    return null;
  }

  function guardedPairs() {
    const pairs = new Set();
    for (const resource of resources()) {
      for (const pair of resource.guards || []) {
        pairs.add(`${pair[0]}|${pair[1]}`);
        pairs.add(`${pair[1]}|${pair[0]}`);
      }
    }
    return pairs;
  }

  function connected(a, b) {
    return edges().some((edge) => {
      const [s, t] = ends(edge);
      return (s === a && t === b) || (s === b && t === a);
    });
  }

  function addEdge(a, b) {
    if (a === b || connected(a, b)) {
      say(
        a === b
          ? gettext("An edge joins two different waypoints.")
          : interpolate(gettext("%(a)s and %(b)s are joined already."), { a, b }, true),
      );
      return;
    }
    edges().push([a, b]);
    changed();
    say(interpolate(gettext("Edge %(a)s – %(b)s added (unsaved)."), { a, b }, true));
  }

  function removeEdge(edge) {
    const list = edges();
    list.splice(list.indexOf(edge), 1);
    const [a, b] = ends(edge);
    for (const resource of resources()) {
      if (Array.isArray(resource.guards)) {
        resource.guards = resource.guards.filter(
          (p) => !((p[0] === a && p[1] === b) || (p[0] === b && p[1] === a)),
        );
      }
    }
    if (selectedEdge === edge) {
      selectedEdge = null;
    }
    changed();
  }

  function freeCode() {
    const taken = new Set(floorsOf().flatMap((f) => (f.waypoints || []).map((wp) => wp.code)));
    let n = 1;
    while (taken.has(`${floor}-WP-${n}`)) {
      n += 1;
    }
    return `${floor}-WP-${n}`;
  }

  function addWaypoint(code, x, y) {
    if (findWaypoint(code)) {
      say(interpolate(gettext("There is already a waypoint %(code)s."), { code }, true));
      return false;
    }
    waypoints(); // the floor's list exists from here on
    floorData().waypoints.push({ code, x: round(x), y: round(y), kind: "plain" });
    selected = code;
    selectedEdge = null;
    changed();
    return true;
  }

  function removeWaypoint(code) {
    const f = floorData();
    f.waypoints = f.waypoints.filter((wp) => wp.code !== code);
    f.edges = edges().filter((edge) => !ends(edge).includes(code));
    for (const resource of resources()) {
      if (Array.isArray(resource.waiting)) {
        resource.waiting = resource.waiting.filter((c) => c !== code);
      }
      if (Array.isArray(resource.guards)) {
        resource.guards = resource.guards.filter((p) => !p.includes(code));
      }
      if (resource.stops && typeof resource.stops === "object") {
        for (const [key, value] of Object.entries(resource.stops)) {
          if (value === code) {
            delete resource.stops[key];
          }
        }
      }
    }
    selected = null;
    changed();
  }

  function recode(old, code) {
    const swap = (c) => (c === old ? code : c);
    findWaypoint(old).code = code;
    for (const f of floorsOf()) {
      f.edges = (f.edges || []).map((edge) =>
        Array.isArray(edge) ? edge.map(swap) : { ...edge, from: swap(edge.from), to: swap(edge.to) },
      );
    }
    for (const resource of resources()) {
      if (Array.isArray(resource.waiting)) {
        resource.waiting = resource.waiting.map(swap);
      }
      if (Array.isArray(resource.guards)) {
        resource.guards = resource.guards.map((p) => p.map(swap));
      }
      if (resource.stops && typeof resource.stops === "object") {
        for (const key of Object.keys(resource.stops)) {
          resource.stops[key] = swap(resource.stops[key]);
        }
      }
    }
    for (const robot of listOf(draft.document, "robots")) {
      robot.dock = swap(robot.dock);
    }
    selected = code;
    changed();
  }

  function round(value) {
    return Math.round(value * 10) / 10;
  }

  // --- Drawing ------------------------------------------------------------------------------

  function computeFrame() {
    const points = waypoints().filter((wp) => Number.isFinite(wp.x) && Number.isFinite(wp.y));
    const xs = points.map((wp) => wp.x);
    const ys = points.map((wp) => wp.y);
    const minX = xs.length ? Math.min(...xs) : 0;
    const maxY = ys.length ? Math.max(...ys) : 0;
    const width = Math.max((xs.length ? Math.max(...xs) : 0) - minX, MIN_SIZE) + 2 * PAD;
    const height = Math.max(maxY - (ys.length ? Math.min(...ys) : 0), MIN_SIZE / 2) + 2 * PAD;
    return { minX, maxY, width, height };
  }

  function place(wp) {
    return [wp.x - frame.minX + PAD, frame.maxY - wp.y + PAD];
  }

  function floorPoint(event) {
    const point = svg.createSVGPoint();
    point.x = event.clientX;
    point.y = event.clientY;
    const inner = point.matrixTransform(svg.getScreenCTM().inverse());
    return { x: inner.x + frame.minX - PAD, y: frame.maxY + PAD - inner.y };
  }

  function element(name, attributes, parent) {
    const node = document.createElementNS(SVG, name);
    for (const [key, value] of Object.entries(attributes)) {
      node.setAttribute(key, value);
    }
    parent.append(node);
    return node;
  }

  function symbol(wp, group) {
    // The fleet page's symbols (templates/robots/_floor_map.html).
    if (wp.kind === "station") {
      element("circle", { r: "1.3", class: "wp-station" }, group);
    } else if (wp.kind === "dock") {
      element("rect", { x: "-1.1", y: "-1.1", width: "2.2", height: "2.2", class: "wp-dock" }, group);
    } else if (wp.kind === "resource_wait") {
      element("path", { d: "M0 -1.4 L1.4 0 L0 1.4 L-1.4 0 Z", class: "wp-resource_wait" }, group);
    } else if (wp.kind === "refuge") {
      element("path", { d: "M0 -1.4 L1.3 1.1 L-1.3 1.1 Z", class: "wp-refuge" }, group);
    } else {
      element("circle", { r: "0.7", class: "wp-plain" }, group);
    }
  }

  function drawMap() {
    if (!dragging) {
      frame = computeFrame();
    }
    svg.setAttribute("viewBox", `0 0 ${frame.width} ${frame.height}`);
    const edgeLayer = $("editor-edges");
    const pointLayer = $("editor-waypoints");
    edgeLayer.replaceChildren();
    pointLayer.replaceChildren();
    const guarded = guardedPairs();
    for (const edge of edges()) {
      const [a, b] = ends(edge).map((code) => waypoints().find((wp) => wp.code === code));
      if (!a || !b) {
        continue; // a dangling edge: the check names it
      }
      const [x1, y1] = place(a);
      const [x2, y2] = place(b);
      let css = guarded.has(`${a.code}|${b.code}`) ? "edge edge-guarded" : "edge";
      if (edge === selectedEdge) {
        css += " selected";
      }
      const line = element("line", { x1, y1, x2, y2, class: css }, edgeLayer);
      line.dataset.edge = `${a.code}|${b.code}`;
      element("title", {}, line).textContent = interpolate(gettext("Edge %(a)s – %(b)s"), { a: a.code, b: b.code }, true);
      line.addEventListener("pointerdown", (event) => {
        if (mode() === "select") {
          event.stopPropagation();
          selectedEdge = edge;
          selected = null;
          renderAll();
          svg.focus();
        }
      });
    }
    for (const wp of waypoints()) {
      const [x, y] = place(wp);
      const css = `wp wp-kind-${wp.kind || "plain"}${wp.code === selected || wp.code === edgeStart ? " selected" : ""}`;
      const group = element("g", { class: css, transform: `translate(${x} ${y})` }, pointLayer);
      group.dataset.waypoint = wp.code;
      element("title", {}, group).textContent = `${wp.name || wp.code} (${wp.code})`;
      symbol(wp, group);
      element("text", { y: "-2.1", "text-anchor": "middle", class: "wp-label" }, group).textContent =
        wp.kind === "station" || wp.kind === "dock" ? wp.name || wp.code : wp.code;
      group.addEventListener("pointerdown", (event) => waypointPressed(event, wp));
    }
  }

  // --- The side panels ----------------------------------------------------------------------

  function renderFloors() {
    const select = $("editor-floor");
    select.replaceChildren();
    for (const f of floorsOf()) {
      const option = new Option(f.name ? `${f.code} – ${f.name}` : f.code, f.code);
      option.selected = f.code === floor;
      select.append(option);
    }
    const current = floorData();
    $("editor-floor-name").textContent = current ? current.name || current.code : "";
  }

  function renderSelected() {
    const wp = selected ? findWaypoint(selected) : null;
    $("selected-form").hidden = !wp;
    $("selected-none").hidden = Boolean(wp);
    if (!wp) {
      return;
    }
    $("wp-code").value = wp.code;
    $("wp-name").value = wp.name || "";
    for (const input of document.querySelectorAll("[data-name-language]")) {
      input.value = (wp.names || {})[input.dataset.nameLanguage] || "";
    }
    $("wp-kind").value = wp.kind || "plain";
    $("wp-x").value = wp.x;
    $("wp-y").value = wp.y;
    const list = $("wp-edges");
    list.replaceChildren();
    for (const edge of edges().filter((e) => ends(e).includes(wp.code))) {
      const [a, b] = ends(edge);
      const item = document.createElement("li");
      item.textContent = `${a} – ${b}`;
      const button = document.createElement("button");
      button.type = "button";
      button.className = "button-small button-quiet";
      button.textContent = interpolate(gettext("Remove edge %(a)s – %(b)s"), { a, b }, true);
      button.addEventListener("click", () => {
        removeEdge(edge);
        renderAll();
      });
      item.append(button);
      list.append(item);
    }
    const connect = $("wp-connect");
    connect.replaceChildren();
    for (const other of waypoints()) {
      if (other.code !== wp.code && !connected(wp.code, other.code)) {
        connect.append(new Option(other.code, other.code));
      }
    }
  }

  function renderList() {
    const list = $("wp-list");
    list.replaceChildren();
    for (const wp of waypoints()) {
      const item = document.createElement("li");
      const button = document.createElement("button");
      button.type = "button";
      button.className = "button-small button-quiet";
      button.textContent = `${wp.code} (${wp.kind || "plain"})${wp.name ? `: ${wp.name}` : ""}`;
      button.setAttribute("aria-pressed", String(wp.code === selected));
      button.addEventListener("click", () => {
        selected = wp.code;
        selectedEdge = null;
        renderAll();
        $("wp-code").focus();
      });
      item.append(button);
      list.append(item);
    }
    $("new-wp-code").value = floor ? freeCode() : "";
  }

  function resourceField(card, label, value, apply, type = "text") {
    const id = `res-${card.dataset.index}-${label.replace(/\W+/g, "-").toLowerCase()}`;
    const field = document.createElement("div");
    field.className = "field";
    const labelNode = document.createElement("label");
    labelNode.htmlFor = id;
    labelNode.textContent = label;
    const input = document.createElement(type === "textarea" ? "textarea" : "input");
    if (type !== "textarea") {
      input.type = type;
    }
    input.id = id;
    input.value = value;
    input.addEventListener("change", () => {
      apply(input.value);
      changed();
      drawMap();
    });
    field.append(labelNode, input);
    card.append(field);
  }

  function renderResources() {
    const list = $("resource-list");
    list.replaceChildren();
    resources().forEach((resource, index) => {
      const card = document.createElement("div");
      card.className = "resource-card";
      card.dataset.index = index;
      const title = document.createElement("h3");
      title.textContent = `${resource.code} (${resource.kind})`;
      card.append(title);
      resourceField(card, gettext("Name"), resource.name || "", (v) => {
        resource.name = v;
      });
      resourceField(
        card,
        gettext("Capacity"),
        resource.capacity ?? 1,
        (v) => {
          resource.capacity = Number.parseInt(v, 10);
        },
        "number",
      );
      if (resource.kind === "elevator") {
        const stops = Object.entries(resource.stops || {}).map(([f, wp]) => `${f}=${wp}`);
        resourceField(card, gettext("Stops"), stops.join(", "), (v) => {
          resource.stops = Object.fromEntries(
            v.split(",").map((part) => part.split("=").map((s) => s.trim())).filter((p) => p[0]),
          );
        });
        resourceField(card, gettext("Seconds per floor"), resource.seconds_per_floor ?? 2, (v) => {
          resource.seconds_per_floor = Number(v);
        }, "number");
        resourceField(card, gettext("Overhead seconds"), resource.overhead_seconds ?? 20, (v) => {
          resource.overhead_seconds = Number(v);
        }, "number");
      } else {
        resourceField(card, gettext("Waiting waypoints"), (resource.waiting || []).join(", "), (v) => {
          resource.waiting = v.split(",").map((s) => s.trim()).filter(Boolean);
        });
        const guards = (resource.guards || []).map((p) => `${p[0]} - ${p[1]}`).join("\n");
        resourceField(card, gettext("Guarded edges"), guards, (v) => {
          resource.guards = v
            .split("\n")
            .map((line) => line.split(/\s+-\s+/).map((s) => s.trim()))
            .filter((p) => p.length === 2 && p[0] && p[1]);
        }, "textarea");
      }
      const remove = document.createElement("button");
      remove.type = "button";
      remove.className = "button-small button-danger";
      remove.textContent = interpolate(gettext("Remove %(code)s"), { code: resource.code }, true);
      remove.addEventListener("click", () => {
        resources().splice(index, 1);
        changed();
        renderAll();
      });
      card.append(remove);
      list.append(card);
    });
  }

  function renderAll() {
    renderFloors();
    drawMap();
    renderSelected();
    renderList();
    renderResources();
  }

  // --- Pointer and keyboard -----------------------------------------------------------------

  function mode() {
    return document.querySelector('input[name="mode"]:checked').value;
  }

  function waypointPressed(event, wp) {
    event.stopPropagation();
    if (mode() === "edge") {
      if (edgeStart === null) {
        edgeStart = wp.code;
        say(interpolate(gettext("Edge from %(code)s: now select the other end."), { code: wp.code }, true));
      } else {
        addEdge(edgeStart, wp.code);
        edgeStart = null;
      }
      renderAll();
      return;
    }
    selected = wp.code;
    selectedEdge = null;
    if (mode() === "select") {
      dragging = true;
      svg.setPointerCapture(event.pointerId);
    }
    renderAll();
    svg.focus();
  }

  svg.addEventListener("pointerdown", (event) => {
    if (mode() !== "add" || !floor) {
      return;
    }
    const at = floorPoint(event);
    if (addWaypoint(freeCode(), at.x, at.y)) {
      say(interpolate(gettext("Waypoint %(code)s added: name it and choose its kind."), { code: selected }, true));
      renderAll();
    }
  });

  svg.addEventListener("pointermove", (event) => {
    if (!dragging || !selected) {
      return;
    }
    const wp = findWaypoint(selected);
    const at = floorPoint(event);
    wp.x = round(at.x);
    wp.y = round(at.y);
    dirty = true;
    drawMap();
  });

  function dragEnd() {
    if (dragging) {
      dragging = false;
      if (dirty) {
        changed();
      }
      renderAll();
    }
  }
  svg.addEventListener("pointerup", dragEnd);
  svg.addEventListener("pointercancel", dragEnd);

  svg.addEventListener("keydown", (event) => {
    const moves = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
    if (moves[event.key] && selected) {
      const step = event.shiftKey ? 0.1 : 1;
      const wp = findWaypoint(selected);
      wp.x = round(wp.x + moves[event.key][0] * step);
      wp.y = round(wp.y + moves[event.key][1] * step);
      changed();
      renderAll();
      event.preventDefault();
    } else if (event.key === "Delete" || event.key === "Backspace") {
      if (selectedEdge) {
        removeEdge(selectedEdge);
      } else if (selected) {
        removeWaypoint(selected);
      }
      renderAll();
      event.preventDefault();
    } else if (event.key === "Escape") {
      selected = selectedEdge = edgeStart = null;
      renderAll();
    }
  });

  // --- The forms ----------------------------------------------------------------------------

  $("editor-floor").addEventListener("change", (event) => {
    floor = event.target.value;
    selected = selectedEdge = edgeStart = null;
    renderAll();
  });

  $("wp-code").addEventListener("change", (event) => {
    const code = event.target.value.trim();
    if (!code || /\s/.test(code)) {
      say("A code is one word, without spaces.");
    } else if (code !== selected && findWaypoint(code)) {
      say(interpolate(gettext("There is already a waypoint %(code)s."), { code }, true));
    } else if (code !== selected) {
      recode(selected, code);
    }
    renderAll();
  });

  for (const [id, key] of [["wp-name", "name"], ["wp-kind", "kind"], ["wp-x", "x"], ["wp-y", "y"]]) {
    $(id).addEventListener("change", (event) => {
      const wp = findWaypoint(selected);
      const value = event.target.value;
      if (key === "x" || key === "y") {
        if (value !== "" && Number.isFinite(Number(value))) {
          wp[key] = round(Number(value));
        }
      } else if (key === "name" && value === "") {
        delete wp.name;
      } else {
        wp[key] = value;
      }
      changed();
      renderAll();
    });
  }

  // A name per language (the site file's `names`); an emptied one is taken away.
  for (const input of document.querySelectorAll("[data-name-language]")) {
    input.addEventListener("change", () => {
      const wp = findWaypoint(selected);
      const names = { ...(wp.names || {}) };
      const language = input.dataset.nameLanguage;
      if (input.value.trim()) {
        names[language] = input.value.trim();
      } else {
        delete names[language];
      }
      if (Object.keys(names).length) {
        wp.names = names;
      } else {
        delete wp.names;
      }
      changed();
      renderAll();
    });
  }

  $("selected-form").addEventListener("submit", (event) => event.preventDefault());

  $("wp-connect-add").addEventListener("click", () => {
    const other = $("wp-connect").value;
    if (selected && other) {
      addEdge(selected, other);
      renderAll();
    }
  });

  $("wp-remove").addEventListener("click", () => {
    removeWaypoint(selected);
    renderAll();
  });

  $("wp-add-form").addEventListener("submit", (event) => {
    event.preventDefault();
    const code = $("new-wp-code").value.trim();
    if (code && addWaypoint(code, Number($("new-wp-x").value), Number($("new-wp-y").value))) {
      renderAll();
      $("wp-name").focus();
    }
  });

  $("resource-add").addEventListener("click", () => {
    const code = $("new-resource-code").value.trim();
    const kind = $("new-resource-kind").value;
    if (!code) {
      say(gettext("Give the new resource a code."));
      return;
    }
    const resource = { code, kind, capacity: 1 };
    if (kind === "elevator") {
      Object.assign(resource, { stops: {}, seconds_per_floor: 2.5, overhead_seconds: 20 });
    } else {
      Object.assign(resource, { waiting: [], guards: [] });
    }
    resources().push(resource);
    $("new-resource-code").value = "";
    changed();
    renderAll();
  });

  $("editor-save").addEventListener("click", save);

  function listInto(id, lines) {
    const list = $(id);
    list.replaceChildren();
    for (const line of lines) {
      const item = document.createElement("li");
      item.textContent = line;
      list.append(item);
    }
  }

  function showImpact(data) {
    const lines = (data.blockers || []).map((b) => interpolate(gettext("Blocks publishing: %(why)s"), { why: b }, true));
    for (const route of data.routes || []) {
      const said =
        $("editor-rollout").value === "replan"
          ? gettext("Robot %(robot)s’s current route crosses %(places)s: will be re-planned")
          : gettext("Robot %(robot)s’s current route crosses %(places)s: blocks publishing");
      lines.push(interpolate(said, { robot: route.robot, places: route.crosses.join(", ") }, true));
    }
    listInto("check-impact", lines.length ? lines : [gettext("No robot’s route or pending delivery is touched.")]);
  }

  async function check() {
    if (!(await save())) {
      return null;
    }
    const answer = await api(root.dataset.checkUrl, "GET");
    if (!answer.ok) {
      say(interpolate(gettext("Could not check: %(errors)s"), { errors: errorsOf(answer.data).join("; ") }, true));
      return null;
    }
    const data = answer.data;
    listInto("check-problems", data.problems.length ? data.problems : [gettext("None: the draft is valid.")]);
    listInto(
      "check-changes",
      data.changes.length
        ? data.changes.map((c) => `${c.what} ${c.how}: ${c.code}${c.detail ? ` (${c.detail})` : ""}`)
        : [gettext("None: the draft is the live map.")],
    );
    showImpact(data);
    say(
      interpolate(
        gettext("Checked: %(problems)s problem(s), %(changes)s change(s)."),
        { problems: data.problems.length, changes: data.changes.length },
        true,
      ),
    );
    return data;
  }

  $("editor-check").addEventListener("click", check);

  $("editor-publish").addEventListener("click", async () => {
    if (!(await save())) {
      return;
    }
    const body = { revision: draft.revision, note: $("publish-note").value };
    const answer = await api(root.dataset.publishUrl, "POST", body);
    const result = $("publish-result");
    if (answer.ok) {
      result.textContent = interpolate(gettext("Published version %(number)s."), { number: answer.data.number }, true);
      if (answer.data.replanned.length) {
        result.textContent += ` Re-planned: ${answer.data.replanned.join(", ")}.`;
      }
      $("publish-note").value = "";
      await load();
      await check();
    } else if (answer.status === 409 && answer.data && answer.data.error === "blocked") {
      result.textContent = gettext("Not published: robots or deliveries are in the way (below).");
      showImpact(answer.data.detail);
    } else {
      const problems = errorsOf(answer.data);
      result.textContent = interpolate(gettext("Not published: %(count)s problem(s). The live map is unchanged."), { count: problems.length }, true);
      listInto("check-problems", problems);
    }
  });

  $("editor-rollout").addEventListener("change", async (event) => {
    const answer = await api(root.dataset.rolloutUrl, "PUT", { rollout: event.target.value });
    if (answer.ok) {
      draft.revision = answer.data.revision;
      $("draft-revision").textContent = draft.revision;
      say(gettext("Saved the site’s choice."));
    } else {
      say(interpolate(gettext("Not saved: %(errors)s"), { errors: errorsOf(answer.data).join("; ") }, true));
    }
  });

  $("editor-upload").addEventListener("change", async (event) => {
    const file = event.target.files[0];
    if (!file) {
      return;
    }
    const text = await file.text();
    const body = { revision: draft.revision, name: file.name, text };
    const answer = await api(root.dataset.uploadUrl, "POST", body);
    if (answer.ok) {
      took(answer.data);
      say(interpolate(gettext("%(file)s is now the draft: check it, then publish."), { file: file.name }, true));
    } else {
      say(
        interpolate(
          gettext("%(file)s was not taken: %(errors)s"),
          { file: file.name, errors: errorsOf(answer.data).join("; ") },
          true,
        ),
      );
    }
    event.target.value = "";
  });

  $("editor-reset").addEventListener("click", async () => {
    const asking = gettext(
      "Discard every edit of the draft, saved or not? The draft becomes the live map again; " +
        "the edits cannot be brought back.",
    );
    if (!window.confirm(asking)) {
      return;
    }
    const answer = await api(root.dataset.resetUrl, "POST", { revision: draft.revision });
    if (answer.ok) {
      took(answer.data);
      say(gettext("The draft is the live map again."));
    } else {
      say(interpolate(gettext("Not discarded: %(errors)s"), { errors: errorsOf(answer.data).join("; ") }, true));
    }
  });

  // Leaving with edits not yet saved: the browser asks first.
  window.addEventListener("beforeunload", (event) => {
    if (dirty) {
      event.preventDefault();
      event.returnValue = "";
    }
  });

  load();
})();
