/*
 * A shared workstation's page: a badge reader types the badge's number and then Enter, which
 * would send the order before the PIN is typed. Enter in the badge field moves on to the PIN.
 * Without this script the server asks for the PIN (and the badge again).
 */
(function () {
  "use strict";

  const badge = document.getElementById("id_badge");
  const pin = document.getElementById("id_pin");
  if (!badge || !pin) {
    return;
  }
  badge.addEventListener("keydown", (event) => {
    if (event.key === "Enter") {
      event.preventDefault();
      pin.focus();
    }
  });
})();
