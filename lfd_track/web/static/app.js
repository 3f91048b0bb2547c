// lfd-track teach: the page side of the WebSocket protocol (see lfd_track/web/app.py).
// The message types and the heartbeat period come from the server (lfd_track/web/contract.py,
// written into the page as the "lfd-contract" data block); this script has no copy of them.
"use strict";
(function () {
  const meta = (name) => document.querySelector(`meta[name="${name}"]`).content;
  const token = meta("lfd-token");
  const query = token ? `?token=${encodeURIComponent(token)}` : "";
  const online = meta("lfd-online") === "true";
  const contract = JSON.parse(document.getElementById("lfd-contract").textContent);
  // A name the contract lacks (renamed on the server's side only) fails loudly, not as undefined.
  const strict = (table, what) => new Proxy(Object.freeze(table), {
    get(target, name) {
      if (!(name in target)) throw new Error(`the station's contract has no ${what} ${String(name)}`);
      return target[name];
    },
  });
  const TO_SERVER = strict(contract.to_server, "message type");
  const TO_PAGE = strict(contract.to_page, "message type");
  const VIEW = strict(contract.view_tags, "view tag");
  const HEARTBEAT_MS = contract.heartbeat_ms;  // the server stops the robot after 1 s without one
  const $ = (id) => document.getElementById(id);
  const camera = $("camera"), topdown = $("topdown");
  const driveButtons = [...document.querySelectorAll("[data-command]")];
  const pauseButton = document.querySelector('[data-action="pause-learning"]');
  const takeoverButton = document.querySelector('[data-action="takeover"]');
  const stopButton = document.querySelector('[data-action="stop"]');
  document.body.classList.toggle("online", online);

  // State the tests (and curious users) can read from the console.
  const lfd = (window.lfd = { frames: 0, status: null, role: null, connected: false, errors: [] });
  let ws = null, pressed = null;

  function send(message) {
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(message));
  }

  function show(img, bytes) {
    const url = URL.createObjectURL(new Blob([bytes], { type: "image/jpeg" }));
    const old = img.dataset.url;
    img.src = url;
    img.dataset.url = url;
    if (old) URL.revokeObjectURL(old);
  }

  const fmt = (v, digits) => (v === null || v === undefined ? "–" : Number(v).toFixed(digits));

  function render(s) {
    lfd.status = s;
    lfd.role = s.role;
    const controller = s.role === "controller";
    $("mode").textContent = s.mode === "autonomous" ? "policy drives" : "human drives";
    $("mode").classList.toggle("autonomous", s.mode === "autonomous");
    $("role").textContent = controller ? "you control" : "watching";
    $("role").classList.toggle("controller", controller);
    $("claim").hidden = controller || !s.control_free;  // free, or its holder went quiet
    driveButtons.forEach((b) => (b.disabled = !controller));
    pauseButton.disabled = !controller;
    pauseButton.setAttribute("aria-pressed", String(!!s.learning_paused));
    takeoverButton.disabled = !controller || !s.policy_ready || s.mode === "autonomous";
    takeoverButton.classList.toggle("offer", !!s.takeover_offered && s.mode !== "autonomous");
    takeoverButton.textContent = s.takeover_offered ? "it agrees with you: let it drive" : "let it drive";
    const learning = $("learning");
    learning.textContent = s.learning_paused
      ? "library learning paused (by you)"
      : s.learning_auto_paused
        ? "library learning paused by the rule: safe box off the felt"
        : "library learning on";
    learning.classList.toggle("warn", !!(s.learning_paused || s.learning_auto_paused));
    $("cases").textContent = s.cases;
    const c = s.counts || {};
    $("counts").textContent = `${c.forward || 0} / ${c.left || 0} / ${c.right || 0}`;
    $("library_models").textContent = s.library_models;
    $("corrections").textContent = s.corrections ?? 0;
    $("generation").textContent = s.generation ?? "–";
    $("best_fitness").textContent = fmt(s.best_fitness, 3);
    $("agreement").textContent = s.agreement === null || s.agreement === undefined
      ? "–" : `${Math.round(100 * s.agreement)} %`;
    const note = s.error ? `error: ${s.error}` : s.stopped_reason ? `stopped: ${s.stopped_reason}` : "";
    if (note) message(note, true);
    else if (statusNote) message("", true);  // the robot moves again: the old note is stale
  }

  let statusNote = false;  // whether the message line shows the status's stop or error note
  function message(text, fromStatus = false) {
    $("message").textContent = text;
    statusNote = fromStatus && text !== "";
  }

  function connect() {
    ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws${query}`);
    ws.binaryType = "arraybuffer";
    ws.onopen = () => { lfd.connected = true; message(""); };
    ws.onclose = (event) => {
      if (event.reason) message(`disconnected: ${event.reason}`);  // e.g. too many messages
      lfd.connected = false;
      lfd.role = null;
      $("role").textContent = "disconnected";
      $("role").classList.remove("controller");
      driveButtons.forEach((b) => (b.disabled = true));
      setTimeout(connect, 1000);
    };
    ws.onmessage = (event) => {
      if (typeof event.data !== "string") {
        const bytes = new Uint8Array(event.data);
        if (bytes[0] === VIEW.CAMERA) { show(camera, bytes.subarray(1)); lfd.frames += 1; }
        else if (bytes[0] === VIEW.TOPDOWN) { show(topdown, bytes.subarray(1)); topdown.hidden = false; }
        return;
      }
      const data = JSON.parse(event.data);
      if (data.type === TO_PAGE.STATUS) render(data);
      else if (data.type === TO_PAGE.ERROR) { lfd.errors.push(data.message); message(data.message); }
    };
  }

  setInterval(() => { if (lfd.role === "controller") send({ type: TO_SERVER.HEARTBEAT }); }, HEARTBEAT_MS);

  function press(command) {
    if (lfd.role !== "controller") return;
    pressed = command;
    driveButtons.forEach((b) => b.classList.toggle("active", b.dataset.command === command));
    send({ type: TO_SERVER.PRESS, command });
  }
  function release() {
    if (pressed === null) return;
    pressed = null;
    driveButtons.forEach((b) => b.classList.remove("active"));
    send({ type: TO_SERVER.RELEASE });
  }
  function stop() { release(); send({ type: TO_SERVER.STOP }); }

  driveButtons.forEach((b) => {
    b.addEventListener("pointerdown", (e) => { e.preventDefault(); press(b.dataset.command); });
    ["pointerup", "pointerleave", "pointercancel"].forEach((t) => b.addEventListener(t, release));
    b.addEventListener("contextmenu", (e) => e.preventDefault());  // long press on a phone
  });
  stopButton.addEventListener("click", stop);
  pauseButton.addEventListener("click", () =>
    send({ type: TO_SERVER.PAUSE_LEARNING, paused: pauseButton.getAttribute("aria-pressed") !== "true" }));
  takeoverButton.addEventListener("click", () => send({ type: TO_SERVER.TAKEOVER }));
  $("claim").addEventListener("click", () => send({ type: TO_SERVER.CLAIM }));

  const KEYS = { ArrowUp: "forward", ArrowLeft: "left", ArrowRight: "right" };
  document.addEventListener("keydown", (e) => {
    if (e.key === " ") { e.preventDefault(); stop(); return; }
    const command = KEYS[e.key];
    if (!command) return;
    e.preventDefault();
    if (!e.repeat) press(command);
  });
  document.addEventListener("keyup", (e) => { if (KEYS[e.key] && KEYS[e.key] === pressed) release(); });
  window.addEventListener("blur", release);
  document.addEventListener("visibilitychange", () => { if (document.hidden) release(); });

  connect();
})();
