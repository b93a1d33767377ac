/*
 * Live pages: one websocket per page to the site's events (daphne, /ws/sites/<site>).
 *
 * On every (re)connect the page re-reads the parts it shows from /live/<site>/state.json, so
 * nothing is stale after a lost connection or a server restart; then it applies events as they
 * come. A closed socket is reopened with backoff. Page scripts (deliveries.js, fleet.js,
 * robot.js) say which parts they show and what to do with events, through window.Live.
 *
 * Hand-written, no framework, no build step: served as is by the app (whitenoise).
 */
(function () {
  "use strict";

  // A risky action (a form or its button with data-confirm) asks first, saying what follows;
  // on every page, parts re-read live included.
  document.addEventListener("submit", (event) => {
    const asking = (event.submitter && event.submitter.dataset.confirm) || event.target.dataset.confirm;
    if (asking && !window.confirm(asking)) {
      event.preventDefault();
    }
  });

  // A nurse's pinned station (static/js/station.js), one click away on every page.
  try {
    const mine = JSON.parse(localStorage.getItem("hd-my-station") || "null");
    const nav = document.querySelector(".mainnav");
    if (mine && mine.url && nav) {
      const link = document.createElement("a");
      link.href = mine.url;
      link.textContent = interpolate(gettext("My station: %(name)s"), { name: mine.name }, true);
      nav.append(link);
    }
  } catch (error) {
    // storage unavailable or garbled: no link
  }

  const body = document.body;
  const site = body.dataset.site;
  if (!site) {
    return;
  }
  const meta = (name) => {
    const element = document.querySelector(`meta[name="${name}"]`);
    return element ? element.content : "";
  };
  const statusElement = document.getElementById("live-status");
  const timeZone = meta("hd-time-zone") || undefined;
  const handlers = {};
  const parts = new Set(["alerts"]);
  const query = {};
  const pending = new Set();
  let socket = null;
  let attempt = 0;
  let retryTimer = null;
  let rereadTimer = null;
  let closedForGood = false;

  // --- Connection ---------------------------------------------------------------------------

  function socketUrl() {
    const configured = meta("hd-websocket-url").replace(/\/+$/, "");
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    const port = meta("hd-websocket-port");
    const host = port ? `${location.hostname}:${port}` : location.host; // one origin by default
    const base = configured || `${scheme}://${host}`;
    return `${base}/ws/sites/${encodeURIComponent(site)}`;
  }

  function setStatus(state, text) {
    body.dataset.live = state;
    if (statusElement) {
      statusElement.dataset.state = state;
      statusElement.textContent = text;
    }
  }

  function connect() {
    if (closedForGood || (socket && socket.readyState <= WebSocket.OPEN)) {
      return;
    }
    clearTimeout(retryTimer);
    setStatus("connecting", attempt ? gettext("Reconnecting…") : gettext("Connecting…"));
    try {
      socket = new WebSocket(socketUrl());
    } catch (error) {
      retryLater();
      return;
    }
    socket.addEventListener("open", () => {
      attempt = 0;
      // "Live" only once the page shows the state as of now: events from here on apply to it.
      reread(new Set(parts)).then((ok) => {
        if (ok && socket && socket.readyState === WebSocket.OPEN) {
          setStatus("open", gettext("Live"));
        }
      });
    });
    socket.addEventListener("message", (message) => {
      let event;
      try {
        event = JSON.parse(message.data);
      } catch (error) {
        return;
      }
      dispatch(event.kind, event.data);
    });
    socket.addEventListener("close", (closed) => {
      socket = null;
      if (closed.code === 4401) {
        toLogin();
      } else if (closed.code === 4403 || closed.code === 4404) {
        closedForGood = true;
        setStatus("closed", gettext("No live updates"));
      } else {
        retryLater();
      }
    });
  }

  function retryLater() {
    attempt += 1;
    // 1 s, 2 s, 4 s, 8 s, then every 15 s; jittered so restarted servers are not stampeded.
    const delay = Math.min(15000, 500 * 2 ** Math.min(attempt, 5)) * (0.75 + Math.random() / 2);
    setStatus("reconnecting", gettext("Reconnecting…"));
    clearTimeout(retryTimer);
    retryTimer = setTimeout(connect, delay);
  }

  function reconnectNow() {
    if (!socket && !closedForGood) {
      attempt = 0;
      connect();
    }
  }

  function toLogin() {
    closedForGood = true;
    setStatus("closed", gettext("Logged out"));
    const next = encodeURIComponent(location.pathname + location.search);
    location.assign(`${body.dataset.loginUrl}?next=${next}`);
  }

  // --- Re-reading the state -----------------------------------------------------------------

  function reread(wanted) {
    const url = new URL(body.dataset.stateUrl, location.href);
    url.searchParams.set("parts", [...wanted].join(","));
    Object.entries(query).forEach(([key, value]) => url.searchParams.set(key, value));
    return fetch(url, { credentials: "same-origin", headers: { Accept: "application/json" } })
      .then((response) => {
        if (response.redirected && new URL(response.url).pathname === body.dataset.loginUrl) {
          toLogin();
          return false;
        }
        if (!response.ok) {
          throw new Error(`state: HTTP ${response.status}`);
        }
        return response.json().then((state) => {
          applyState(state);
          return true;
        });
      })
      .catch(() => false); // the next event or reconnect reads again
  }

  function rereadSoon(part, delay = 300) {
    pending.add(part);
    if (!rereadTimer) {
      rereadTimer = setTimeout(() => {
        rereadTimer = null;
        const wanted = new Set(pending);
        pending.clear();
        reread(wanted);
      }, delay);
    }
  }

  function applyState(state) {
    Object.entries(state.parts || {}).forEach(([name, html]) => replacePart(name, html));
    dispatch("state", state);
  }

  function replacePart(name, html) {
    document.querySelectorAll(`[data-part="${name}"]`).forEach((element) => {
      const focus = focusKey(element);
      const fresh = document.createElement("template");
      fresh.innerHTML = html;
      morphChildren(element, fresh.content);
      if (focus && !element.contains(document.activeElement)) {
        restoreFocus(element, focus);
      }
    });
  }

  // --- Morphing a part into its re-read HTML ------------------------------------------------
  //
  // A re-read part is patched node by node instead of replaced, so what a person is doing in it
  // survives live events: the control with the focus stays the same element (its caret and
  // selection with it), and a value typed or picked but not yet sent is kept.

  const KEY_ATTRIBUTES = ["id", "data-task", "data-robot", "data-alert", "data-resource"];

  function nodeKey(node) {
    if (node.nodeType !== Node.ELEMENT_NODE) {
      return null;
    }
    const attribute = KEY_ATTRIBUTES.find((name) => node.hasAttribute(name));
    return attribute ? `${node.nodeName} ${attribute}=${node.getAttribute(attribute)}` : null;
  }

  function morphChildren(target, source) {
    const keyed = new Map();
    target.childNodes.forEach((child) => {
      const key = nodeKey(child);
      if (key) {
        keyed.set(key, child);
      }
    });
    let cursor = target.firstChild;
    [...source.childNodes].forEach((wanted) => {
      const key = nodeKey(wanted);
      let match = key ? keyed.get(key) : null;
      if (!key && cursor && !nodeKey(cursor) && cursor.nodeName === wanted.nodeName) {
        match = cursor;
      }
      if (!match) {
        target.insertBefore(wanted, cursor);
        return;
      }
      keyed.delete(key);
      if (match === cursor) {
        cursor = cursor.nextSibling;
      } else {
        target.insertBefore(match, cursor);
      }
      morphNode(match, wanted);
    });
    while (cursor) {
      const next = cursor.nextSibling;
      cursor.remove();
      cursor = next;
    }
  }

  function morphNode(target, source) {
    if (target.nodeType !== Node.ELEMENT_NODE) {
      if (target.nodeValue !== source.nodeValue) {
        target.nodeValue = source.nodeValue;
      }
      return;
    }
    const kept = heldInput(target);
    [...target.attributes].forEach(({ name }) => {
      if (!source.hasAttribute(name)) {
        target.removeAttribute(name);
      }
    });
    [...source.attributes].forEach(({ name, value }) => {
      if (target.getAttribute(name) !== value) {
        target.setAttribute(name, value);
      }
    });
    morphChildren(target, source);
    if (kept) {
      kept();
    }
  }

  /** A control being used (focused, or changed and not sent): a function that puts back what
   * the person typed or picked after the patch; null for any other element. */
  function heldInput(element) {
    if (element instanceof HTMLSelectElement) {
      const picked = [...element.options].map((option) => option.selected);
      const changed = [...element.options].some((option) => option.selected !== option.defaultSelected);
      if (!changed && element !== document.activeElement) {
        return null;
      }
      const values = [...element.options].filter((_, index) => picked[index]).map((option) => option.value);
      return () => [...element.options].forEach((option) => {
        option.selected = values.includes(option.value);
      });
    }
    if (!(element instanceof HTMLInputElement || element instanceof HTMLTextAreaElement)) {
      return null;
    }
    if (element.type === "checkbox" || element.type === "radio") {
      const checked = element.checked;
      return checked === element.defaultChecked ? null : () => (element.checked = checked);
    }
    const value = element.value;
    if (value === element.defaultValue && element !== document.activeElement) {
      return null;
    }
    return () => {
      if (element.value !== value) {
        element.value = value;
      }
    };
  }

  // A part patched under the keyboard focus that lost the focused control gives it back to the
  // same control of the same row.
  const ROW_KEYS = ["task", "robot", "alert", "resource"];

  function focusKey(container) {
    const active = document.activeElement;
    if (!active || !container.contains(active)) {
      return null;
    }
    const row = active.closest(ROW_KEYS.map((key) => `[data-${key}]`).join(","));
    if (!row) {
      return null;
    }
    const key = ROW_KEYS.find((name) => row.dataset[name] !== undefined);
    const focusables = [...row.querySelectorAll("a, button, input, select, textarea")];
    return { key, value: row.dataset[key], index: focusables.indexOf(active) };
  }

  function restoreFocus(container, focus) {
    const row = container.querySelector(`[data-${focus.key}="${CSS.escape(focus.value)}"]`);
    const focusables = row ? [...row.querySelectorAll("a, button, input, select, textarea")] : [];
    (focusables[focus.index] || focusables[0] || container.closest("[tabindex]") || body).focus();
  }

  // --- Events -------------------------------------------------------------------------------

  function on(kind, handler) {
    (handlers[kind] = handlers[kind] || []).push(handler);
  }

  function dispatch(kind, data) {
    (handlers[kind] || []).forEach((handler) => handler(data));
  }

  on("alert", () => rereadSoon("alerts", 0));
  on("alert_acknowledged", (data) => {
    document.querySelectorAll(`[data-alert="${CSS.escape(String(data.id))}"]`).forEach((el) => {
      if (!el.contains(document.activeElement)) {
        el.remove();
      } else {
        rereadSoon("alerts", 0);
      }
    });
  });

  // --- Showing robots (fleet rows, the robot page) ------------------------------------------

  const clock = new Intl.DateTimeFormat("en-GB", {
    timeZone,
    hour: "2-digit",
    minute: "2-digit",
    second: "2-digit",
    hour12: false,
  });

  function formatTime(iso) {
    return iso ? clock.format(new Date(iso)) : "";
  }

  function element(tag, className, text) {
    const made = document.createElement(tag);
    if (className) {
      made.className = className;
    }
    if (text !== undefined) {
      made.textContent = text;
    }
    return made;
  }

  const muted = (text) => element("span", "muted", text);

  const ROBOT_FIELDS = {
    presence: (r) => [element("span", `presence presence-${r.presence}`, r.presence_label)],
    status: (r) => {
      const nodes = [document.createTextNode(r.status_label)];
      if (r.paused_by_operator) {
        nodes.push(document.createTextNode(" "), element("span", "badge badge-hold", gettext("held by operator")));
      }
      if (r.held_after_fault) {
        const text = gettext("held after a fault: Resume or send it to its dock");
        nodes.push(document.createTextNode(" "), element("span", "badge badge-error", text));
      }
      if (r.in_maintenance) {
        const badge = element("span", "badge badge-hold", gettext("in maintenance"));
        badge.dataset.badge = "maintenance";
        nodes.push(document.createTextNode(" "), badge);
      }
      if (r.sent_to_charge) {
        const badge = element("span", "badge badge-hold", gettext("sent to charge: no tasks until charged"));
        badge.dataset.badge = "charge";
        nodes.push(document.createTextNode(" "), badge);
      }
      if (r.errors && r.errors.length) {
        nodes.push(document.createTextNode(" "), element("span", "badge badge-error", r.errors.join(", ")));
      }
      return nodes;
    },
    place: (r, cell) => {
      if (!r.floor) {
        return [muted("—")];
      }
      const nodes = [document.createTextNode(r.place ? `${r.floor} · ${r.place}` : r.floor)];
      if (r.waypoint && cell.hasAttribute("data-with-code")) {
        // operators also get the place's code, as the map, the plans and the robots name it
        nodes.push(document.createTextNode(" "), element("span", "muted small place-code", r.waypoint));
      }
      return nodes;
    },
    position: (r) =>
      r.x === null || r.x === undefined
        ? [muted("—")]
        : [document.createTextNode(`x ${r.x.toFixed(1)} m, y ${r.y.toFixed(1)} m`)],
    battery: (r) => {
      if (r.battery === null || r.battery === undefined) {
        return [muted("—")];
      }
      const battery = element("span", r.battery < 20 ? "battery battery-low" : "battery");
      const bar = element("span", "battery-bar");
      bar.style.setProperty("--level", `${r.battery}%`);
      battery.append(bar, `${r.battery} %`);
      return [battery];
    },
    load: (r) => [document.createTextNode(`${r.load} / ${r.capacity}`)],
    last_seen: (r) => {
      if (!r.last_seen_at) {
        return [muted("never")];
      }
      const time = element("time", "", formatTime(r.last_seen_at));
      time.dateTime = r.last_seen_at;
      return [time];
    },
  };

  /** Show robot `r` (a "robot" event's data) in every [data-field] inside `container`. */
  function showRobot(container, r) {
    container.querySelectorAll("[data-field]").forEach((cell) => {
      const render = ROBOT_FIELDS[cell.dataset.field];
      if (render) {
        cell.replaceChildren(...render(r, cell));
      }
    });
    if (container.matches("tr")) {
      container.className = `presence-${r.presence}`;
    }
  }

  // --- Start ----------------------------------------------------------------------------------

  window.Live = {
    /** The page shows these parts: they are re-read on every (re)connect. */
    want: (...names) => names.forEach((name) => parts.add(name)),
    /** An extra query parameter of the re-read (the robot page's robot). */
    query: (key, value) => {
      query[key] = value;
    },
    on,
    rereadSoon,
    showRobot,
    formatTime,
  };

  document.addEventListener("DOMContentLoaded", connect);
  window.addEventListener("online", reconnectNow);
  document.addEventListener("visibilitychange", () => {
    if (document.visibilityState === "visible") {
      reconnectNow();
    }
  });
})();
