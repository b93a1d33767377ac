/*
 * A station's page, live: re-read on every task and robot event; a new announcement (a robot
 * about to arrive, or waiting at the station) plays a short sound unless the user turned it
 * off; "waiting N min" counts up. "Make this my station" keeps it in this browser (live.js
 * shows the link in the menu).
 */
(function () {
  "use strict";

  const page = document.querySelector("[data-station-page]");
  if (!window.Live || !page) {
    return;
  }
  const SOUND_KEY = "hd-sound";
  const MINE_KEY = "hd-my-station";
  const heard = new Set([...page.querySelectorAll("[data-announce]")].map((el) => el.dataset.announce));
  const soundButton = page.querySelector("[data-sound]");
  const pinButton = page.querySelector("[data-pin-station]");

  const soundOn = () => localStorage.getItem(SOUND_KEY) !== "off";

  function showSound() {
    soundButton.hidden = false;
    soundButton.setAttribute("aria-pressed", String(soundOn()));
    soundButton.textContent = soundOn() ? gettext("Sound on") : gettext("Sound off");
  }

  soundButton.addEventListener("click", () => {
    localStorage.setItem(SOUND_KEY, soundOn() ? "off" : "on");
    showSound();
  });
  showSound();

  function showPinned() {
    pinButton.textContent = gettext("This is my station");
    pinButton.disabled = true;
  }

  pinButton.hidden = false;
  pinButton.addEventListener("click", () => {
    localStorage.setItem(MINE_KEY, JSON.stringify({ url: page.dataset.stationUrl, name: page.dataset.stationName }));
    showPinned();
  });
  try {
    const mine = JSON.parse(localStorage.getItem(MINE_KEY) || "null");
    if (mine && mine.url === page.dataset.stationUrl) {
      showPinned(); // pinned before, in this browser
    }
  } catch (error) {
    // garbled: offer to pin it
  }

  function chime() {
    const Context = window.AudioContext || window.webkitAudioContext;
    if (!soundOn() || !Context) {
      return;
    }
    const audio = new Context();
    const tone = audio.createOscillator();
    const volume = audio.createGain();
    tone.frequency.value = 880;
    volume.gain.setValueAtTime(0.2, audio.currentTime);
    volume.gain.exponentialRampToValueAtTime(0.001, audio.currentTime + 0.6);
    tone.connect(volume).connect(audio.destination);
    tone.start();
    tone.stop(audio.currentTime + 0.6);
  }

  function announceNew() {
    let fresh = false;
    page.querySelectorAll("[data-announce]").forEach((el) => {
      if (!heard.has(el.dataset.announce)) {
        heard.add(el.dataset.announce);
        fresh = true;
      }
    });
    if (fresh) {
      page.dataset.announced = String(Number(page.dataset.announced || 0) + 1);
      chime();
    }
  }

  function tick() {
    page.querySelectorAll("time[data-since]").forEach((el) => {
      const minutes = Math.max(0, Math.floor((Date.now() - Date.parse(el.dataset.since)) / 60000));
      el.textContent =
        minutes < 1 ? gettext("less than a minute") : interpolate(gettext("%(minutes)s min"), { minutes }, true);
    });
  }

  Live.want("station");
  Live.query("station", page.dataset.stationPage);
  Live.on("task", () => Live.rereadSoon("station"));
  Live.on("robot", () => Live.rereadSoon("station", 1000));
  Live.on("state", () => {
    announceNew();
    tick();
  });
  tick();
  setInterval(tick, 15000);
})();
