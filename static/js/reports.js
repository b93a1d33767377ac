// The reports page: one Chart.js chart per table, drawn from the same rows as the table and its
// CSV (embedded by the server with json_script). Chart.js is vendored in static/vendor/.
(function () {
  "use strict";
  var COLOURS = ["#1f6feb", "#d9480f", "#2f9e44", "#ae3ec9", "#f08c00", "#c92a2a", "#495057"];

  function draw(section) {
    var key = section.dataset.report;
    var data = JSON.parse(document.getElementById("data-" + key).textContent);
    var canvas = document.getElementById("chart-" + key);
    var labels = data.rows.map(function (row) { return String(row[data.label]); });
    var datasets = data.series.map(function (series, n) {
      return {
        label: series.label,
        data: data.rows.map(function (row) { return row[series.key]; }),
        backgroundColor: COLOURS[n % COLOURS.length],
      };
    });
    new window.Chart(canvas, {
      type: data.type,
      data: { labels: labels, datasets: datasets },
      options: {
        animation: false,
        responsive: true,
        maintainAspectRatio: false,
        scales: { x: { stacked: data.stacked }, y: { stacked: data.stacked, beginAtZero: true } },
        plugins: { legend: { display: datasets.length > 1 } },
      },
    });
    section.dataset.chart = "drawn";
  }

  document.querySelectorAll("[data-report]").forEach(draw);
})();
