// The URSLink dashboard: the linked spaces, live, through urs-gateway's Foxglove WebSocket
// endpoint (protocol.js). Everything shown comes from the gateway's channels; everything done goes
// through its services (docs/dashboard.md). Plain DOM and SVG; no library, nothing fetched from
// elsewhere.
"use strict";

const SVG = "http://www.w3.org/2000/svg";
const $ = (id) => document.getElementById(id);

// The lab of the papers' experiments (docs/experiments.md; devices/camera default_lab()): the room
// and its wall markers; the square path's waypoints.
const LAB = {
  width: 6.5,
  depth: 4.0,
  markers: [[1, 6.5, 1.0], [2, 6.5, 3.0], [3, 3.0, 4.0], [4, 0.0, 2.0], [5, 2.0, 0.0], [6, 5.0, 0.0]],
  square: [[1.5, 1.0], [1.5, 3.0], [5.0, 3.0], [5.0, 1.0], [1.5, 1.0]],
};
const ROBOT_COLORS = ["#d9480f", "#2f6fd6", "#2e9d3a", "#9c36b5", "#e8590c", "#0b7285"];
const KEEP_SECONDS = 120;   // recent poses kept per robot for the plots
const LOG_ROWS = 400;
const TRAIL_SPACING = 0.1;  // m, as the gateway's trails: more than a localizer's noise

const state = {
  client: null,
  session: null,      // this browser's login id (for the Foxglove URL)
  loggedOut: false,
  role: null,
  credential: null,  // {identity, server_role}: what the CAMUS server said of this login's credential
  graph: null,
  services: [],
  components: [],
  robots: new Map(),  // "<space>/<robot>" -> {space, robot, pose, trail: [[x,y,t]], recent: [[t,x,y]], rate}
  context: new Map(), // "<space>/<key>" -> entry
  log: [],            // newest last
  poseLog: [],        // the pose streams' rows, kept apart so they never push the rest out
  seenMarkers: new Map(),  // "x,y" -> {id, x, y, at}
  dirty: new Set(),
  selectedComponent: null,
  plotted: 0,         // when the plots were last drawn
};

function el(tag, attrs = {}, parent = null, text = null) {
  const node = tag.startsWith("svg:") ? document.createElementNS(SVG, tag.slice(4)) : document.createElement(tag);
  for (const [key, value] of Object.entries(attrs)) {
    if (value !== undefined && value !== null) node.setAttribute(key, value);
  }
  if (text !== null) node.textContent = text;
  if (parent) parent.appendChild(node);
  return node;
}
const svg = (tag, attrs, parent, text) => el("svg:" + tag, attrs, parent, text);
function clear(node) { while (node.firstChild) node.removeChild(node.firstChild); }
function markDirty(...panels) { for (const p of panels) state.dirty.add(p); }
function short(json, n = 160) { const s = typeof json === "string" ? json : JSON.stringify(json); return s.length > n ? s.slice(0, n) + "…" : s; }
function time(seconds) { return seconds ? new Date(seconds * 1000).toLocaleTimeString() : ""; }

// ---- login and connection ------------------------------------------------------------------------

async function api(path, body) {
  const options = body === undefined ? {} : { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) };
  const response = await fetch(path, options);
  const json = await response.json().catch(() => ({}));
  if (!response.ok) throw new Error(json.error || response.statusText);
  return json;
}

async function start() {
  $("login-form").addEventListener("submit", async (event) => {
    event.preventDefault();
    $("login-error").textContent = "";
    try {
      const login = await api("/api/login", { credential: $("credential").value });
      $("credential").value = "";
      state.session = login.session;
      state.credential = login.identity ? { identity: login.identity, server_role: login.server_role } : null;
      state.loggedOut = false;
      connect();
    } catch (error) {
      $("login-error").textContent = error.message;
    }
  });
  $("logout-button").addEventListener("click", async () => {
    await api("/api/logout", {}).catch(() => {});
    state.session = null;
    state.credential = null;
    state.loggedOut = true;
    if (state.client) state.client.close();
    showLogin(true);
  });
  $("call-button").addEventListener("click", callSelected);
  $("operation").addEventListener("change", () => renderCallForm());
  $("service-filter").addEventListener("input", () => markDirty("services"));
  for (const id of ["log-kind", "log-space", "log-filter", "log-poses"]) $(id).addEventListener("input", () => markDirty("log"));
  $("plot-robot").addEventListener("change", () => markDirty("plots"));
  $("run-square").addEventListener("click", runSquare);
  $("run-speeds").addEventListener("click", runSpeeds);
  try {
    const who = await api("/api/whoami");
    $("space-name").textContent = who.space;
    state.credential = who.identity ? { identity: who.identity, server_role: who.server_role } : null;
    if (who.role) connect(); else showLogin(true);
  } catch (error) {
    showLogin(true);
  }
  requestAnimationFrame(frame);
}

// Why this connection may or may not act: an operator acts; anyone else only sees (the gateway
// refuses their calls with PERMISSION_DENIED).
function roleExplained() {
  const who = state.credential
    ? "the CAMUS server gives credential '" + state.credential.identity + "' the role " + state.credential.server_role
    : "";
  if (state.role === "operator") return "operator: sees and acts" + (who ? " (" + who + ")" : "");
  return "viewer: sees everything, acts on nothing" + (who ? " (" + who + ")" : "") +
    "; calls, lifecycle changes and context need a credential with the role operator";
}

function showLogin(visible) {
  $("login-form").hidden = !visible;
  $("logout-button").hidden = visible;
  if (visible) $("role").textContent = "";
}

function connect() {
  if (state.client) state.client.close();
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  const client = new FoxgloveClient(scheme + "//" + location.host + "/");
  state.client = client;
  client.onopen = (info) => {
    state.role = (info.metadata && info.metadata.role) || "viewer";
    // A gateway playing a recording (urs play) says so: what is shown is not live.
    const playback = info.metadata && info.metadata.playback === "true";
    $("connection").textContent = playback ? "playing a recording" : "live";
    $("connection").className = "badge online";
    $("role").textContent = state.role;
    $("role").title = roleExplained();
    for (const id of ["run-square", "run-speeds"]) {
      $(id).disabled = state.role !== "operator";
      $(id).title = state.role === "operator" ? "" : roleExplained();
    }
    $("space-name").textContent = (info.metadata && info.metadata.space) || "";
    showLogin(false);
    if (state.session) {
      $("foxglove").hidden = false;
      $("foxglove-url").textContent = scheme + "//" + location.host + "/?session=" + state.session;
    }
    markDirty("services", "components", "call");
  };
  client.onclose = () => {
    $("connection").textContent = "offline";
    $("connection").className = "badge offline";
    if (state.client !== client || state.loggedOut) return;
    // Connect again while this browser may; a login that ended asks for the credential again.
    setTimeout(async () => {
      if (state.client !== client || state.loggedOut) return;
      const who = await api("/api/whoami").catch(() => ({}));
      if (who.role) connect(); else showLogin(true);
    }, 2000);
  };
  client.onstatus = (status) => { $("status-line").textContent = status.message; };
  client.onservices = () => markDirty("call", "services");
  client.subscribe("/graph", (graph) => { state.graph = graph; markDirty("spaces"); });
  client.subscribe("/services", (message) => { state.services = message.services || []; markDirty("services", "spaces", "call"); });
  client.subscribe("/components", (message) => { state.components = message.components || []; markDirty("components", "spaces"); });
  client.subscribe("/trails", onTrail);
  client.subscribe("/poses", onPose);
  client.subscribe("/context", onContext);
  client.subscribe("/events", onEvent);
  client.connect();
}

// ---- streams ------------------------------------------------------------------------------------

function robotOf(space, name) {
  const key = space + "/" + name;
  let robot = state.robots.get(key);
  if (!robot) {
    robot = { key, space, robot: name, pose: null, trail: [], recent: [], count: 0, since: performance.now(), rate: 0,
              color: ROBOT_COLORS[state.robots.size % ROBOT_COLORS.length] };
    state.robots.set(key, robot);
    const option = el("option", { value: key }, $("plot-robot"), key);
    if (state.robots.size === 1) option.selected = true;
  }
  return robot;
}

function onTrail(trail) {
  const robot = robotOf(trail.space, trail.robot);
  if (robot.trail.length < (trail.points || []).length) robot.trail = trail.points.map((p) => [p.x, p.y, p.stamp]);
  markDirty("map", "plots");
}

function onPose(pose) {
  const robot = robotOf(pose.space, pose.robot);
  robot.pose = pose;
  const last = robot.trail[robot.trail.length - 1];
  if (!last || Math.hypot(last[0] - pose.x, last[1] - pose.y) >= TRAIL_SPACING) {
    robot.trail.push([pose.x, pose.y, pose.stamp]);
    if (robot.trail.length > 2000) robot.trail.shift();
  }
  robot.recent.push([pose.stamp, pose.x, pose.y]);
  while (robot.recent.length && robot.recent[0][0] < pose.stamp - KEEP_SECONDS) robot.recent.shift();
  robot.count++;
  const elapsed = (performance.now() - robot.since) / 1000;
  if (elapsed >= 2) {
    robot.rate = robot.count / elapsed;
    robot.count = 0;
    robot.since = performance.now();
  }
  markDirty("map", "plots");
}

function addLog(row) {
  const log = /pose/.test(row.name) ? state.poseLog : state.log;
  log.push(row);
  if (log.length > LOG_ROWS) log.shift();
  markDirty("log");
}

// A google.protobuf.Value travels as its JSON text (docs/dashboard.md, "Schema rules").
function jsonText(text) {
  if (typeof text !== "string") return text;
  try { return JSON.parse(text); } catch (error) { return text; }
}

function onContext(message) {
  const entry = Object.assign({}, message, { value: jsonText(message.value) });
  const key = entry.space + "/" + entry.key;
  if (entry.removed) state.context.delete(key); else state.context.set(key, entry);
  addLog({ t: entry.stamp, space: entry.space, kind: "context", name: entry.key, source: entry.source,
           payload: entry.removed ? "(removed)" : entry.value });
  addSpaceOption(entry.space);
}

function onEvent(message) {
  const event = Object.assign({}, message, { payload: jsonText(message.payload) });
  addLog({ t: event.stamp, space: event.space, kind: "event", name: event.topic, source: event.source, payload: event.payload });
  addSpaceOption(event.space);
  // A task's run, as the experiments started here see it.
  if (/^task\//.test(event.topic) && event.payload && event.payload.task) {
    const run = event.payload;
    $("experiment-status").textContent = run.task + ": run " + run.run_id + " " + run.state +
      (run.state === "running" ? " (step " + run.step + " of " + run.steps + ")" : run.message ? " — " + run.message : "");
  }
  // The camera's recognitions: markers "urs:marker:<id>@<x>,<y>" light up on the map.
  if (/\/markers$/.test(event.topic) && event.payload && Array.isArray(event.payload.result)) {
    for (const marker of event.payload.result) {
      const m = /^urs:marker:(\d+)@([-\d.]+),([-\d.]+)$/.exec(marker.content || "");
      if (m) state.seenMarkers.set(m[2] + "," + m[3], { id: m[1], x: +m[2], y: +m[3], at: performance.now() });
    }
    markDirty("map");
  }
}

function addSpaceOption(space) {
  const select = $("log-space");
  for (const option of select.options) if (option.value === space) return;
  el("option", { value: space }, select, space);
}

// ---- rendering (once per animation frame, only what changed) ---------------------------------------

function frame() {
  const dirty = state.dirty;
  state.dirty = new Set();
  try {
    if (dirty.has("spaces")) renderSpaces();
    if (dirty.has("services")) renderServices();
    if (dirty.has("components")) renderComponents();
    if (dirty.has("map")) renderMap();
    // The plots and their table follow poses a few times a second, not at every frame.
    if (dirty.has("plots")) {
      if (performance.now() - state.plotted >= 250) {
        renderPlots();
        state.plotted = performance.now();
      } else {
        state.dirty.add("plots");
      }
    }
    if (dirty.has("log")) renderLog();
    if (dirty.has("call")) renderOperations();
  } finally {
    requestAnimationFrame(frame);
  }
}

// The linked spaces side by side: each space's middlewares, services (with origin) and bridges,
// and the DDS link between the bridges.
function renderSpaces() {
  const root = $("spaces");
  clear(root);
  const graph = state.graph;
  if (!graph) return;
  const spaces = graph.spaces || [];
  const width = root.clientWidth || 900;
  const column = Math.max(220, Math.min(420, (width - 20) / Math.max(1, spaces.length)));
  const top = 8;
  const boxHeight = 200;
  const bridgeY = top + boxHeight + 10;
  let linkXs = [];
  spaces.forEach((space, i) => {
    const x = 10 + i * column;
    const g = svg("g", { "data-space": space.name }, root);
    svg("rect", { x, y: top, width: column - 20, height: boxHeight, rx: 6, class: "box" + (space.local ? " local" : "") }, g);
    svg("text", { x: x + 10, y: top + 18, class: "title" }, g, space.name + (space.local ? "  (this gateway)" : ""));
    svg("text", { x: x + 10, y: top + 34, class: "small" }, g,
        (space.middlewares || []).join(" + ") + " · " + space.services + " services · " + space.components + " components");
    const services = state.services.filter((s) => s.space === space.name);
    services.slice(0, 9).forEach((service, j) => {
      svg("text", { x: x + 12, y: top + 54 + j * 15 }, g, "● " + service.name);
      svg("text", { x: x + column - 30, y: top + 54 + j * 15, class: "small", "text-anchor": "end" }, g, service.origin.split(":")[0]);
    });
    if (services.length > 9) svg("text", { x: x + 12, y: top + 54 + 9 * 15, class: "small" }, g, "+ " + (services.length - 9) + " more");
    (space.bridges || []).forEach((bridge, j) => {
      const bx = x + 10 + j * 110;
      svg("rect", { x: bx, y: bridgeY, width: 100, height: 24, rx: 4, class: "bridge" }, g);
      svg("text", { x: bx + 50, y: bridgeY + 16, "text-anchor": "middle" }, g, bridge.name);
      svg("line", { x1: bx + 50, y1: top + boxHeight, x2: bx + 50, y2: bridgeY, class: "connection" }, g);
      linkXs.push(bx + 50);
    });
  });
  if (graph.dds && linkXs.length) {
    const y = bridgeY + 36;
    const x1 = Math.min(...linkXs), x2 = Math.max(...linkXs) + (linkXs.length === 1 ? 60 : 0);
    svg("path", { d: `M ${x1} ${y} L ${x2} ${y}`, class: "link" }, root);
    for (const x of linkXs) svg("line", { x1: x, y1: bridgeY + 24, x2: x, y2: y, class: "link" }, root);
    svg("text", { x: x1 + 4, y: y + 14 }, root, "DDS link, domain " + graph.dds_domain + " (catalog, state, poses, events, calls)");
  }
  root.setAttribute("height", bridgeY + 70);
}

function renderServices() {
  const body = $("services").tBodies[0];
  clear(body);
  const filter = $("service-filter").value.toLowerCase();
  const rows = state.services
    .filter((s) => !filter || JSON.stringify(s).toLowerCase().includes(filter))
    .sort((a, b) => (a.space + a.name).localeCompare(b.space + b.name));
  for (const s of rows) {
    const tr = el("tr", { "data-service": s.space + "/" + s.name }, body);
    for (const value of [s.space, s.name, s.interface, s.origin, s.bridge, s.state, s.seen_via]) el("td", {}, tr, value || "");
  }
}

// RT-Components as RTSystemEditor draws them: a box coloured by state, data in-ports on the left,
// out-ports on the right, service ports below; lines for connections.
function renderComponents() {
  const root = $("rtview");
  clear(root);
  const rtcs = state.components.filter((c) => c.kind === "rtc");
  const width = root.clientWidth || 900;
  const cell = 190, boxW = 120, boxH = 46;
  const perRow = Math.max(1, Math.floor((width - 20) / cell));
  const portAt = new Map();  // "<path>:<port>" -> [x, y]
  rtcs.forEach((c, i) => {
    const x = 30 + (i % perRow) * cell, y = 20 + Math.floor(i / perRow) * 110;
    const g = svg("g", { "data-component": c.name, class: "rtc" }, root);
    const fill = { Active: "#8fd694", Inactive: "#9ec1f7", Error: "#f29b9b", Created: "#ddd" }[c.state] || "#bbb";
    const box = svg("rect", { x, y, width: boxW, height: boxH, rx: 4, fill, class: "component" }, g);
    box.addEventListener("click", () => { state.selectedComponent = c.name; markDirty("components"); });
    const label = c.name.split("/").pop().replace(/\.rtc$/, "");
    svg("text", { x: x + boxW / 2, y: y + 19, "text-anchor": "middle" }, g, label);
    svg("text", { x: x + boxW / 2, y: y + 34, "text-anchor": "middle", class: "small" }, g, c.state + " · " + c.space);
    const ins = c.ports.filter((p) => p.kind === "DataInPort");
    const outs = c.ports.filter((p) => p.kind === "DataOutPort");
    const services = c.ports.filter((p) => p.kind !== "DataInPort" && p.kind !== "DataOutPort");
    ins.forEach((p, j) => {
      const py = y + 8 + j * 12;
      svg("rect", { x: x - 8, y: py, width: 8, height: 8, fill: "#fff", class: "port" }, g);
      svg("text", { x: x - 10, y: py + 7, "text-anchor": "end", class: "small" }, g, p.name);
      portAt.set(c.name + ":" + p.name, [x - 8, py + 4]);
    });
    outs.forEach((p, j) => {
      const py = y + 8 + j * 12;
      svg("rect", { x: x + boxW, y: py, width: 8, height: 8, fill: "#333", class: "port" }, g);
      svg("text", { x: x + boxW + 10, y: py + 7, class: "small" }, g, p.name);
      portAt.set(c.name + ":" + p.name, [x + boxW + 8, py + 4]);
    });
    services.forEach((p, j) => {
      const px = x + 8 + j * 26;
      const provided = (p.interfaces || []).some((f) => f.polarity === "provided");
      svg(provided ? "circle" : "rect", provided ? { cx: px + 4, cy: y + boxH + 4, r: 4, fill: "#ffd43b", class: "port" }
                                                 : { x: px, y: y + boxH, width: 8, height: 8, fill: "#ffd43b", class: "port" }, g);
      svg("text", { x: px, y: y + boxH + 20, class: "small" }, g, p.name);
      portAt.set(c.name + ":" + p.name, [px + 4, y + boxH + 8]);
    });
  });
  const drawn = new Set();
  for (const c of rtcs) {
    for (const p of c.ports) {
      for (const connection of p.connections || []) {
        if (drawn.has(connection.id)) continue;
        drawn.add(connection.id);
        const points = (connection.ports || []).map((name) => portAt.get(name)).filter(Boolean);
        for (let k = 1; k < points.length; k++) {
          const [a, b] = [points[0], points[k]];
          const midY = Math.max(a[1], b[1]) + 14;
          svg("path", { d: `M ${a[0]} ${a[1]} L ${a[0]} ${midY} L ${b[0]} ${midY} L ${b[0]} ${b[1]}`, class: "connection",
                        "data-connection": connection.id }, root);
        }
      }
    }
  }
  root.setAttribute("height", 40 + Math.ceil(rtcs.length / perRow) * 110);

  const body = $("components").tBodies[0];
  clear(body);
  const operator = state.role === "operator";
  for (const c of [...state.components].sort((a, b) => (a.space + a.name).localeCompare(b.space + b.name))) {
    const tr = el("tr", { "data-component": c.name, "data-space": c.space }, body);
    for (const value of [c.space, c.name, c.kind, c.type_name]) el("td", {}, tr, value || "");
    el("td", { class: "state state-" + c.state }, tr, c.state);
    el("td", {}, tr, c.origin || "");
    const actions = el("td", {}, tr);
    if (c.lifecycle) {
      for (const transition of ["activate", "deactivate", "reset"]) {
        const button = el("button", { class: "lifecycle", "data-transition": transition }, actions, transition);
        button.disabled = !operator || !state.client || !state.client.services.has(c.name + "/" + transition);
        if (!operator) button.title = roleExplained();
        button.addEventListener("click", () => lifecycle(c.name, transition));
      }
    }
  }
}

async function lifecycle(component, transition) {
  $("status-line").textContent = transition + " " + component + "…";
  try {
    const reply = await state.client.call(component + "/" + transition, {});
    $("status-line").textContent = component + " is " + reply.state;
  } catch (error) {
    $("status-line").textContent = transition + " " + component + ": " + error.message;
  }
}

// The lab: the room, its markers (lit when the camera recognises them), each robot's trail and pose.
function renderMap() {
  const root = $("map");
  clear(root);
  let maxX = LAB.width, maxY = LAB.depth, minX = 0, minY = 0;
  for (const robot of state.robots.values()) {
    for (const [x, y] of robot.trail) { maxX = Math.max(maxX, x); maxY = Math.max(maxY, y); minX = Math.min(minX, x); minY = Math.min(minY, y); }
  }
  root.setAttribute("viewBox", `${minX - 0.5} ${-(maxY + 0.5)} ${maxX - minX + 1} ${maxY - minY + 1}`);
  // y grows northwards: everything is drawn with y negated.
  const world = svg("g", {}, root);
  svg("rect", { x: 0, y: -LAB.depth, width: LAB.width, height: LAB.depth, class: "room" }, world);
  for (let gx = 1; gx < LAB.width; gx++) svg("line", { x1: gx, y1: 0, x2: gx, y2: -LAB.depth, class: "grid-line" }, world);
  for (let gy = 1; gy < LAB.depth; gy++) svg("line", { x1: 0, y1: -gy, x2: LAB.width, y2: -gy, class: "grid-line" }, world);
  svg("polyline", { points: LAB.square.map(([x, y]) => `${x},${-y}`).join(" "), class: "waypoint" }, world);
  const now = performance.now();
  const markers = new Map(LAB.markers.map(([id, x, y]) => [x.toFixed(1) + "," + y.toFixed(1), { id, x, y }]));
  for (const seen of state.seenMarkers.values()) markers.set(seen.x.toFixed(1) + "," + seen.y.toFixed(1), seen);
  for (const [key, m] of markers) {
    // Lit while the camera sees it (3 s after its last recognition), tinted once it has been seen.
    const sighting = [...state.seenMarkers.values()].find((s) => s.x.toFixed(1) + "," + s.y.toFixed(1) === key);
    const seen = sighting && now - sighting.at < 3000;
    svg("rect", { x: m.x - 0.1, y: -m.y - 0.1, width: 0.2, height: 0.2,
                  class: "marker" + (sighting ? " recognised" : "") + (seen ? " seen" : ""),
                  "data-marker": m.id }, world);
  }
  const body = $("robots").tBodies[0];
  clear(body);
  for (const robot of state.robots.values()) {
    if (robot.trail.length > 1) {
      svg("polyline", { points: robot.trail.map(([x, y]) => `${x.toFixed(3)},${(-y).toFixed(3)}`).join(" "), class: "trail",
                        stroke: robot.color }, world);
    }
    const pose = robot.pose;
    if (!pose) continue;
    const deg = (pose.theta * 180) / Math.PI;
    const g = svg("g", { class: "robot", "data-robot": robot.key, "data-x": pose.x.toFixed(3), "data-y": pose.y.toFixed(3),
                         transform: `translate(${pose.x} ${-pose.y}) rotate(${-deg})` }, world);
    svg("circle", { r: 0.19, fill: robot.color, "fill-opacity": 0.35, stroke: robot.color, "stroke-width": 0.02 }, g);
    svg("path", { d: "M 0.22 0 L -0.12 0.12 L -0.12 -0.12 Z", fill: robot.color }, g);
    svg("text", { x: pose.x + 0.25, y: -pose.y - 0.25, class: "map-label" }, world, robot.robot);
    const tr = el("tr", { "data-robot": robot.key }, body);
    for (const value of [robot.key, pose.x.toFixed(3), pose.y.toFixed(3), deg.toFixed(1), pose.via, robot.rate.toFixed(1)]) {
      el("td", {}, tr, value);
    }
  }
}

// The experiments' plots, from the chosen robot's poses: its path against the square's waypoints,
// and its speed over the last two minutes.
function renderPlots() {
  const robot = state.robots.get($("plot-robot").value);
  const square = $("square-plot");
  const speed = $("speed-plot");
  clear(square);
  clear(speed);
  const W = 360, H = 240, pad = 30;
  const sx = (x) => pad + (x / LAB.width) * (W - 2 * pad), sy = (y) => H - pad - (y / LAB.depth) * (H - 2 * pad);
  svg("rect", { x: sx(0), y: sy(LAB.depth), width: sx(LAB.width) - sx(0), height: sy(0) - sy(LAB.depth), fill: "none", class: "axis" }, square);
  svg("polyline", { points: LAB.square.map(([x, y]) => `${sx(x)},${sy(y)}`).join(" "), fill: "none", stroke: "#999", "stroke-dasharray": "4 3" }, square);
  svg("text", { x: pad, y: 14 }, square, "square path: trace (blue) and waypoints (dashed), m");
  for (let x = 0; x <= LAB.width; x += 1) svg("text", { x: sx(x), y: H - pad + 14, class: "small", "text-anchor": "middle" }, square, String(x));
  for (let y = 0; y <= LAB.depth; y += 1) svg("text", { x: pad - 6, y: sy(y) + 3, class: "small", "text-anchor": "end" }, square, String(y));
  const body = $("waypoints").tBodies[0];
  clear(body);
  if (!robot) return;
  if (robot.trail.length > 1) svg("polyline", { points: robot.trail.map(([x, y]) => `${sx(x)},${sy(y)}`).join(" "), class: "series" }, square);
  for (const [wx, wy] of LAB.square.slice(0, 4)) {
    // Over the trail and every pose kept (the trail's points are 10 cm apart).
    let best = Infinity;
    for (const [x, y] of robot.trail) best = Math.min(best, Math.hypot(x - wx, y - wy));
    for (const [, x, y] of robot.recent) best = Math.min(best, Math.hypot(x - wx, y - wy));
    const tr = el("tr", {}, body);
    el("td", {}, tr, `(${wx}, ${wy})`);
    el("td", {}, tr, isFinite(best) ? (best * 1000).toFixed(0) : "");
  }
  // Speed: distance over at least 0.25 s between kept poses.
  const points = [];
  const recent = robot.recent;
  let j = 0;
  for (let i = 1; i < recent.length; i++) {
    while (j < i && recent[i][0] - recent[j][0] > 0.5) j++;
    if (j > 0 && recent[i][0] - recent[j - 1][0] >= 0.25) {
      const a = recent[j - 1], b = recent[i];
      points.push([b[0], (Math.hypot(b[1] - a[1], b[2] - a[2]) / (b[0] - a[0])) * 1000]);
    }
  }
  // The time axis spans what is kept: from the first pose kept (at most KEEP_SECONDS ago) to now.
  const SH = 200, end = recent.length ? recent[recent.length - 1][0] : 0;
  const startT = recent.length ? Math.min(recent[0][0], end - 10) : end - KEEP_SECONDS, span = end - startT;
  const maxV = Math.max(1000, ...points.map((p) => p[1]));
  const tx = (t) => pad + ((t - startT) / span) * (W - 2 * pad), vy = (v) => SH - pad - (v / maxV) * (SH - 2 * pad);
  svg("line", { x1: pad, y1: SH - pad, x2: W - pad, y2: SH - pad, class: "axis" }, speed);
  svg("line", { x1: pad, y1: pad, x2: pad, y2: SH - pad, class: "axis" }, speed);
  svg("text", { x: pad, y: 14 }, speed, "speed (mm/s) over the last " + Math.round(span) + " s (at most " + KEEP_SECONDS + ")");
  svg("text", { x: pad, y: SH - pad + 14, class: "small" }, speed, "-" + Math.round(span) + " s");
  svg("text", { x: W - pad, y: SH - pad + 14, class: "small", "text-anchor": "end" }, speed, "now");
  for (const v of [0, 200, 500, 800]) {
    svg("line", { x1: pad, y1: vy(v), x2: W - pad, y2: vy(v), class: "grid-line", stroke: "#e6e9ec" }, speed);
    svg("text", { x: pad - 4, y: vy(v) + 3, class: "small", "text-anchor": "end" }, speed, String(v));
  }
  if (points.length > 1) svg("polyline", { points: points.map(([t, v]) => `${tx(t).toFixed(1)},${vy(v).toFixed(1)}`).join(" "), class: "series" }, speed);
}

function renderLog() {
  const body = $("log").tBodies[0];
  clear(body);
  const kind = $("log-kind").value, space = $("log-space").value, filter = $("log-filter").value.toLowerCase();
  // Pose streams (a localizer's events, the pose context entries) drown the rest unless asked for.
  const rows = $("log-poses").checked ? [...state.log, ...state.poseLog].sort((a, b) => a.t - b.t) : state.log;
  let shown = 0;
  for (let i = rows.length - 1; i >= 0 && shown < 150; i--) {
    const row = rows[i];
    if (kind && row.kind !== kind) continue;
    if (space && row.space !== space) continue;
    const payload = JSON.stringify(row.payload);
    if (filter && !(row.name + " " + payload).toLowerCase().includes(filter)) continue;
    const tr = el("tr", { "data-kind": row.kind }, body);
    for (const value of [time(row.t), row.space, row.kind, row.name, row.source]) el("td", {}, tr, value || "");
    el("td", { class: "json" }, tr, short(payload, 300));
    shown++;
  }
}

// ---- calls ---------------------------------------------------------------------------------------

function renderOperations() {
  const select = $("operation");
  const current = select.value;
  const names = state.client ? [...state.client.services.keys()].sort() : [];
  clear(select);
  el("option", { value: "" }, select, names.length ? "choose an operation (" + names.length + ")" : "no operation offered");
  for (const name of names) {
    const option = el("option", { value: name }, select, name);
    if (name === current) option.selected = true;
  }
  $("call-button").disabled = state.role !== "operator";
  $("call-button").title = state.role === "operator" ? "" : roleExplained();
  if (select.value !== current || !$("call-form").firstChild) renderCallForm();
}

// A form generated from the operation's request schema (the JSON Schema the gateway derived from
// the interface's description): one input per field, nested fieldsets for structs, JSON text for
// sequences and anything else.
function renderCallForm() {
  const form = $("call-form");
  clear(form);
  $("call-result").textContent = "";
  const service = state.client && state.client.services.get($("operation").value);
  if (!service) return;
  const schema = JSON.parse((service.request && service.request.schema) || "{}");
  el("div", { class: "small" }, form, service.type + " (" + (service.request ? service.request.schemaName : "") + ")");
  buildFields(form, schema, "");
}

function typeOf(schema) { return Array.isArray(schema.type) ? schema.type[0] : schema.type; }

function buildFields(parent, schema, path) {
  for (const [name, field] of Object.entries(schema.properties || {})) {
    const key = path ? path + "." + name : name;
    const type = typeOf(field);
    if (type === "object" && field.properties && Object.keys(field.properties).length) {
      const set = el("fieldset", {}, parent);
      el("legend", {}, set, name);
      buildFields(set, field, key);
      continue;
    }
    const label = el("label", {}, parent);
    el("span", {}, label, name);
    let input;
    if (field.enum) {
      input = el("select", { "data-field": key, "data-kind": "enum" }, label);
      for (const value of field.enum) el("option", { value }, input, value);
    } else if (type === "boolean") {
      input = el("input", { type: "checkbox", "data-field": key, "data-kind": "boolean" }, label);
    } else if (type === "number" || (type === "integer" && !Array.isArray(field.type))) {
      input = el("input", { type: "number", step: "any", "data-field": key, "data-kind": "number" }, label);
    } else if (field.contentMediaType === "application/json") {
      // Any JSON value, sent as its text (the gateway reads it back).
      input = el("textarea", { "data-field": key, "data-kind": "string", placeholder: "JSON" }, label);
    } else if (type === "string" || type === "integer") {
      input = el("input", { type: "text", "data-field": key, "data-kind": "string" }, label);
    } else {
      input = el("textarea", { "data-field": key, "data-kind": "json", placeholder: type === "array" ? "[ ]" : "JSON" }, label);
    }
  }
}

// The request the form says, leaving out empty fields (their defaults).
function formRequest() {
  const request = {};
  for (const input of $("call-form").querySelectorAll("[data-field]")) {
    const kind = input.dataset.kind;
    let value;
    if (kind === "boolean") value = input.checked;
    else if (input.value === "") continue;
    else if (kind === "number") value = Number(input.value);
    else if (kind === "json") value = JSON.parse(input.value);
    else value = input.value;
    const parts = input.dataset.field.split(".");
    let target = request;
    for (const part of parts.slice(0, -1)) target = target[part] = target[part] || {};
    target[parts[parts.length - 1]] = value;
  }
  return request;
}

async function callSelected() {
  const name = $("operation").value;
  const result = $("call-result");
  if (!name) return;
  let request;
  try {
    request = formRequest();
  } catch (error) {
    result.className = "failure";
    result.textContent = "the form holds bad JSON: " + error.message;
    return;
  }
  result.className = "";
  result.textContent = "calling " + name + " " + JSON.stringify(request) + " …";
  try {
    const reply = await state.client.call(name, request);
    result.className = "ok";
    result.textContent = JSON.stringify(reply, null, 2);
  } catch (error) {
    result.className = "failure";
    result.textContent = error.message;
  }
}

// ---- the experiments -----------------------------------------------------------------------------

function navigationFor(robotKey) {
  const names = state.client ? [...state.client.services.keys()] : [];
  const robot = (robotKey || "").split("/").pop();
  return names.find((n) => n === robot + ".navigation/setSpeed")
      || names.find((n) => n.endsWith("navigation/setSpeed") && n.includes(robot))
      || names.find((n) => n.endsWith("navigation/setSpeed"));
}

async function runSquare() {
  const status = $("experiment-status");
  try {
    const run = await state.client.call("camus.tasks/Run", { name: "square-path" });
    status.textContent = "square path: run " + run.run_id + " " + run.state;
  } catch (error) {
    status.textContent = "square path: " + error.message;
  }
}

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

async function runSpeeds() {
  const status = $("experiment-status");
  const setSpeed = navigationFor($("plot-robot").value);
  if (!setSpeed) { status.textContent = "no navigation service offered"; return; }
  const base = setSpeed.slice(0, -"setSpeed".length);
  try {
    await state.client.call(base + "setSpeed", { speed: 200 });
    await state.client.call(base + "moveTo", { x: 5.0, y: 1.0 });
    for (const speed of [200, 800, 500, 0]) {
      status.textContent = "speed changes: " + speed + " mm/s";
      await state.client.call(base + "setSpeed", { speed });
      await sleep(2000);
    }
    status.textContent = "speed changes: done";
  } catch (error) {
    status.textContent = "speed changes: " + error.message;
  }
}

start();
