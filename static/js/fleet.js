/*
 * The fleet panel and floor map, live: "robot" events update the robot's row and move its
 * marker on the map; task and lease events re-read the current tasks and the resource table.
 */
(function () {
  "use strict";

  if (!window.Live) {
    return;
  }
  const SVG = "http://www.w3.org/2000/svg";
  const map = document.getElementById("floor-map");
  const markers = document.getElementById("map-robots");

  function row(code) {
    return document.querySelector(`#fleet tr[data-robot="${CSS.escape(code)}"]`);
  }

  function newMarker(code) {
    const marker = document.createElementNS(SVG, "g");
    marker.dataset.robot = code;
    const title = document.createElementNS(SVG, "title");
    const dot = document.createElementNS(SVG, "circle");
    dot.setAttribute("r", "1.8");
    dot.setAttribute("class", "robot-dot");
    const label = document.createElementNS(SVG, "text");
    label.setAttribute("class", "robot-label");
    label.setAttribute("y", "0.6");
    label.textContent = code;
    marker.append(title, dot, label);
    markers.append(marker);
    return marker;
  }

  function moveMarker(r) {
    if (!map || !markers) {
      return;
    }
    let marker = markers.querySelector(`[data-robot="${CSS.escape(r.code)}"]`);
    const here = r.floor === map.dataset.floor && r.x !== null && r.y !== null;
    if (!here) {
      if (marker) {
        marker.remove();
      }
      return;
    }
    marker = marker || newMarker(r.code);
    const margin = Number(map.dataset.margin);
    const x = r.x - Number(map.dataset.minX) + margin;
    const y = Number(map.dataset.maxY) - r.y + margin;
    marker.style.transform = `translate(${x}px, ${y}px)`;
    marker.setAttribute("class", `robot-marker presence-${r.presence}`);
    marker.querySelector("title").textContent =
      `${r.code}: ${r.status_label}${r.place ? `, ${r.place}` : ""} (${r.presence_label.toLowerCase()})`;
  }

  function showRobot(r) {
    const found = row(r.code);
    if (found) {
      Live.showRobot(found, r);
    } else {
      Live.rereadSoon("fleet"); // a robot this page does not list yet
    }
    moveMarker(r);
  }

  Live.want("fleet", "resources");
  Live.on("robot", showRobot);
  Live.on("state", (state) => (state.robots || []).forEach(moveMarker));
  Live.on("task", () => Live.rereadSoon("fleet"));
  Live.on("lease", () => Live.rereadSoon("resources"));
  Live.on("resource", () => Live.rereadSoon("resources"));
})();
