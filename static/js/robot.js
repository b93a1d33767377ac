/*
 * A robot's page, live: its "robot" events update the state panel; anything that may change
 * its plan, tasks or events re-reads those panels (at most every two seconds).
 */
(function () {
  "use strict";

  const page = document.querySelector("[data-robot-page]");
  if (!window.Live || !page) {
    return;
  }
  const code = page.dataset.robotPage;
  const state = page.querySelector(`[data-robot="${CSS.escape(code)}"]`);
  const REREAD_MS = 2000;

  function show(r) {
    if (r.code === code) {
      Live.showRobot(state, r);
    }
  }

  Live.want("robot");
  Live.query("robot", code);
  Live.on("robot", (r) => {
    show(r);
    if (r.code === code) {
      Live.rereadSoon("robot", REREAD_MS);
    }
  });
  Live.on("state", (snapshot) => (snapshot.robots || []).forEach(show));
  Live.on("task", (task) => {
    if (!task.robot || task.robot === code || document.querySelector(`[href$="/${task.code}/"]`)) {
      Live.rereadSoon("robot", REREAD_MS);
    }
  });
  Live.on("lease", (lease) => {
    if (lease.robot === code) {
      Live.rereadSoon("robot", REREAD_MS);
    }
  });
})();
