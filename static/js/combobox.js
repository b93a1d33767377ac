/*
 * Station search: every <input data-combobox="ID"> becomes an editable combobox with a list of
 * suggestions (WAI-ARIA 1.2 combobox pattern, list autocomplete), from the JSON data block ID
 * ([{code, name, ward}], Django's json_script). A suggestion matches when each typed word is in
 * its name, code or ward, anywhere. Keyboard: Down/Up move through the list (Down opens it),
 * Enter takes the highlighted one, Escape closes the list (keeping what was typed), Tab
 * leaves. Inputs added later (another stop) work too: the events are delegated.
 */
(function () {
  "use strict";

  const MAX_SHOWN = 12;
  const boxes = new WeakMap(); // input -> {listbox, options, active}
  let counter = 0;

  function stationsOf(input) {
    const data = document.getElementById(input.dataset.combobox);
    return data ? JSON.parse(data.textContent) : [];
  }

  function fold(text) {
    return (text || "").toLocaleLowerCase().normalize("NFKD").replace(/[\u0300-\u036f]/g, "");
  }

  function matches(station, words) {
    const haystack = fold(`${station.name} ${station.code} ${station.ward}`);
    return words.every((word) => haystack.includes(word));
  }

  function boxOf(input) {
    let box = boxes.get(input);
    if (box) {
      return box;
    }
    // A stop copied from another carries that one's list: drop it, make its own.
    input.parentNode.querySelectorAll("[data-combobox-list]").forEach((stale) => stale.remove());
    counter += 1;
    const listbox = document.createElement("ul");
    listbox.id = `combobox-list-${counter}`;
    listbox.className = "combobox-list";
    listbox.setAttribute("role", "listbox");
    listbox.dataset.comboboxList = "";
    listbox.setAttribute("aria-label", gettext("Stations"));
    listbox.hidden = true;
    input.after(listbox);
    input.setAttribute("role", "combobox");
    input.setAttribute("aria-autocomplete", "list");
    input.setAttribute("aria-expanded", "false");
    input.setAttribute("aria-controls", listbox.id);
    input.removeAttribute("list");
    box = { listbox, stations: stationsOf(input), options: [], active: -1 };
    boxes.set(input, box);
    return box;
  }

  function render(input) {
    const box = boxOf(input);
    const words = fold(input.value).split(/\s+/).filter(Boolean);
    const found = box.stations.filter((station) => matches(station, words)).slice(0, MAX_SHOWN);
    box.listbox.replaceChildren(
      ...found.map((station, index) => {
        const option = document.createElement("li");
        option.id = `${box.listbox.id}-${index}`;
        option.setAttribute("role", "option");
        option.setAttribute("aria-selected", "false");
        option.dataset.value = station.name;
        const name = document.createElement("span");
        name.textContent = station.name;
        const where = document.createElement("span");
        where.className = "combobox-where";
        where.textContent = [station.ward, station.code].filter(Boolean).join(" · ");
        option.append(name, " ", where);
        return option;
      }),
    );
    box.options = [...box.listbox.children];
    box.active = -1;
    input.removeAttribute("aria-activedescendant");
    return box;
  }

  function open(input) {
    const box = render(input);
    // Nothing left to choose once the box holds a station's whole name and only it matches.
    const chosen = box.options.length === 1 && fold(box.options[0].dataset.value) === fold(input.value.trim());
    const any = box.options.length > 0 && !chosen;
    box.listbox.hidden = !any;
    input.setAttribute("aria-expanded", String(any));
    return box;
  }

  function close(input) {
    const box = boxes.get(input);
    if (!box) {
      return;
    }
    box.listbox.hidden = true;
    box.active = -1;
    input.setAttribute("aria-expanded", "false");
    input.removeAttribute("aria-activedescendant");
  }

  function isOpen(input) {
    return input.getAttribute("aria-expanded") === "true";
  }

  function highlight(input, index) {
    const box = boxes.get(input);
    box.options.forEach((option, i) => option.setAttribute("aria-selected", String(i === index)));
    box.active = index;
    const option = box.options[index];
    input.setAttribute("aria-activedescendant", option.id);
    option.scrollIntoView({ block: "nearest" });
  }

  function choose(input, option) {
    input.value = option.dataset.value;
    close(input);
    input.dispatchEvent(new Event("change", { bubbles: true }));
  }

  function move(input, step) {
    const box = isOpen(input) ? boxes.get(input) : open(input);
    if (!box.options.length) {
      return;
    }
    const count = box.options.length;
    const next = box.active < 0 ? (step > 0 ? 0 : count - 1) : (box.active + step + count) % count;
    highlight(input, next);
  }

  const comboboxOf = (target) => (target.matches && target.matches("input[data-combobox]") ? target : null);

  document.addEventListener("input", (event) => {
    const input = comboboxOf(event.target);
    if (input) {
      open(input);
    }
  });

  document.addEventListener("keydown", (event) => {
    const input = comboboxOf(event.target);
    if (!input) {
      return;
    }
    if (event.key === "ArrowDown" || event.key === "ArrowUp") {
      event.preventDefault();
      move(input, event.key === "ArrowDown" ? 1 : -1);
    } else if (event.key === "Enter" && isOpen(input) && boxes.get(input).active >= 0) {
      event.preventDefault(); // take the suggestion, do not send the form yet
      const box = boxes.get(input);
      choose(input, box.options[box.active]);
    } else if (event.key === "Escape" && isOpen(input)) {
      event.preventDefault(); // closes the list; what was typed stays
      close(input);
    } else if (event.key === "Tab") {
      close(input);
    }
  });

  document.addEventListener("focusin", (event) => {
    const input = comboboxOf(event.target);
    if (input) {
      boxOf(input);
    }
  });

  document.addEventListener("focusout", (event) => {
    const input = comboboxOf(event.target);
    if (input) {
      close(input);
    }
  });

  // A pointer: pressing an option must not blur the input first (which would close the list).
  document.addEventListener("mousedown", (event) => {
    if (event.target.closest("[data-combobox-list]")) {
      event.preventDefault();
    }
  });

  document.addEventListener("click", (event) => {
    const option = event.target.closest("[data-combobox-list] [role=option]");
    if (option) {
      choose(option.closest("[data-combobox-list]").previousElementSibling, option);
    }
  });

  // Ready for the keyboard before the first keystroke: the roles and states set at load.
  document.querySelectorAll("input[data-combobox]").forEach(boxOf);
})();
