/*
 * The deliveries page: more pick-ups or drop-offs, the repeat fields that apply, the task
 * history dialog, and the schedule table kept live (window.Live, live.js).
 *
 * Everything here is an enhancement: without it the form still posts (one input per stop),
 * every repeat field shows, and a task code opens its history page.
 */
(function () {
  "use strict";

  // --- More stops ---------------------------------------------------------------------------

  const LABELS = { pickup: gettext("Pick-up"), dropoff: gettext("Drop-off") };

  function renumber(group) {
    const kind = group.dataset.stops;
    group.querySelectorAll("[data-stop]").forEach((stop, index) => {
      const number = index + 1;
      const input = stop.querySelector("input");
      const label = stop.querySelector("label");
      const id = number === 1 ? `id_${kind}` : `id_${kind}_${number}`;
      input.id = id;
      label.htmlFor = id;
      label.textContent = number === 1 ? LABELS[kind] : `${LABELS[kind]} ${number}`;
      const hidden = stop.querySelector("[data-remove-stop] .visually-hidden");
      if (hidden) {
        hidden.textContent = ` ${label.textContent.toLowerCase()}`;
      }
    });
  }

  function removeButton() {
    const button = document.createElement("button");
    button.type = "button";
    button.className = "button-quiet";
    button.dataset.removeStop = "";
    const hidden = document.createElement("span");
    hidden.className = "visually-hidden";
    button.append(gettext("Remove"), hidden);
    return button;
  }

  function addStop(group) {
    const stops = group.querySelectorAll("[data-stop]");
    const copy = stops[stops.length - 1].cloneNode(true);
    copy.classList.remove("has-error");
    copy.querySelectorAll(".field-error").forEach((error) => error.remove());
    const input = copy.querySelector("input");
    input.value = "";
    input.removeAttribute("aria-invalid");
    input.removeAttribute("aria-describedby");
    if (!copy.querySelector("[data-remove-stop]")) {
      copy.querySelector(".stop-input").append(removeButton());
    }
    stops[stops.length - 1].after(copy);
    renumber(group);
    input.focus();
  }

  document.querySelectorAll("[data-add-stop]").forEach((button) => {
    const group = button.closest("[data-stops]");
    button.hidden = false;
    button.addEventListener("click", () => addStop(group));
  });

  document.addEventListener("click", (event) => {
    const remove = event.target.closest("[data-remove-stop]");
    if (!remove) {
      return;
    }
    const group = remove.closest("[data-stops]");
    const stop = remove.closest("[data-stop]");
    const previous = stop.previousElementSibling;
    stop.remove();
    renumber(group);
    (previous && previous.querySelector("input") ? previous.querySelector("input") : group.querySelector("input")).focus();
  });

  // --- Repeat: show the fields of the chosen kind -------------------------------------------

  const repeat = document.getElementById("id_repeat");

  function showRepeatFields() {
    document.querySelectorAll(".repeat-details [data-show-if]").forEach((fields) => {
      fields.hidden = fields.dataset.showIf !== repeat.value;
    });
  }

  if (repeat) {
    repeat.addEventListener("change", showRepeatFields);
    showRepeatFields();
  }

  // --- Task history in a dialog -------------------------------------------------------------

  const dialog = document.getElementById("history-dialog");
  let opener = null;

  // A click anywhere on a task's row (not on its links or buttons) opens its history too; the
  // keyboard reaches it through the code's link.
  document.addEventListener("click", (event) => {
    const row = event.target.closest("#schedule tr[data-task]");
    if (row && !event.target.closest("a, button, form")) {
      const link = row.querySelector("a[data-history]");
      if (link) {
        link.click();
      }
    }
  });

  document.addEventListener("click", (event) => {
    const link = event.target.closest("a[data-history]");
    if (!link || !dialog || event.ctrlKey || event.metaKey || event.shiftKey || event.button) {
      return;
    }
    event.preventDefault();
    const url = new URL(link.href);
    url.searchParams.set("partial", "1");
    fetch(url, { credentials: "same-origin" })
      .then((response) => {
        if (!response.ok) {
          throw new Error(`history: HTTP ${response.status}`);
        }
        return response.text();
      })
      .then((html) => {
        opener = link;
        document.getElementById("history-dialog-title").textContent = interpolate(gettext("Delivery %(code)s"), { code: link.textContent }, true);
        document.getElementById("history-dialog-body").innerHTML = html;
        dialog.showModal();
        dialog.querySelector("[data-close-dialog]").focus();
      })
      .catch(() => location.assign(link.href));
  });

  if (dialog) {
    dialog.querySelector("[data-close-dialog]").addEventListener("click", () => dialog.close());
    dialog.addEventListener("click", (event) => {
      if (event.target === dialog) {
        dialog.close(); // a click on the backdrop
      }
    });
    dialog.addEventListener("close", () => {
      if (opener && opener.isConnected) {
        opener.focus();
      }
    });
  }

  // --- The schedule, live -------------------------------------------------------------------

  if (!window.Live) {
    return;
  }
  Live.want("schedule");
  Live.on("task", (task) => {
    const cell = document.querySelector(
      `#schedule tr[data-task="${CSS.escape(task.code)}"] [data-field="status"]`,
    );
    if (cell) {
      const status = document.createElement("span");
      status.className = `status status-${task.status}`;
      status.textContent = task.status_label;
      cell.replaceChildren(status);
    }
    // A new status brings robot, arrival, new rows: from the server. An entry in the history
    // alone (the robot arrived, a note) changes nothing the row shows but its ETA, which
    // comes by itself ("etas", below): no re-read of every page's schedule for it.
    if (task.old !== task.status) {
      Live.rereadSoon("schedule");
    }
  });
  // A robot's progress moved some ETAs: the cells change in place (no re-read).
  Live.on("etas", (data) => {
    data.tasks.forEach((task) => {
      const row = document.querySelector(`#schedule tr[data-task="${CSS.escape(task.code)}"]`);
      const cell = row && row.querySelector('[data-field="eta"]');
      if (!cell || row.classList.contains("finished") || cell.dataset.onHold !== undefined) {
        return;
      }
      const nodes = [];
      if (task.eta) {
        const time = document.createElement("time");
        time.dateTime = task.eta;
        time.textContent = task.eta_label;
        nodes.push(time);
      } else {
        const none = document.createElement("span");
        none.className = "muted";
        none.textContent = "—";
        nodes.push(none);
      }
      if (task.lateness) {
        const late = document.createElement("div");
        late.className = "late small";
        late.dataset.field = "lateness";
        late.textContent = task.lateness;
        nodes.push(late);
      }
      cell.replaceChildren(...nodes);
    });
  });
  // A robot held, faulty or offline changes what its deliveries' rows say ("Held by an
  // operator", the ETA on hold): re-read them when that, not its position, changes.
  const disrupted = new Map();
  Live.on("robot", (r) => {
    const now = [r.paused_by_operator, r.held_after_fault, r.presence === "offline"].join();
    const before = disrupted.has(r.code) ? disrupted.get(r.code) : "false,false,false";
    disrupted.set(r.code, now);
    if (before !== now) {
      Live.rereadSoon("schedule");
    }
  });
})();
