// Small 2D canvas plots with axes: points or lines, a horizontal reference line, bars.

function prepare(canvas) {
  const ratio = window.devicePixelRatio || 1;
  canvas.width = Math.round(canvas.clientWidth * ratio);
  canvas.height = Math.round(canvas.clientHeight * ratio);
  const context = canvas.getContext("2d");
  context.scale(ratio, ratio);
  return { context, width: canvas.clientWidth, height: canvas.clientHeight };
}

function niceMax(value) {
  if (!(value > 0)) return 1;
  const step = 10 ** Math.floor(Math.log10(value));
  return Math.ceil(value / step) * step;
}

function frame(canvas, xMax, yMax, xLabel, yLabel) {
  const { context, width, height } = prepare(canvas);
  const m = { left: 48, right: 10, top: 10, bottom: 34 };
  const x = (value) => m.left + (value / xMax) * (width - m.left - m.right);
  const y = (value) => height - m.bottom - (value / yMax) * (height - m.top - m.bottom);
  context.strokeStyle = "#98a2b3";
  context.fillStyle = "#475467";
  context.font = "11px system-ui, sans-serif";
  context.beginPath();
  context.moveTo(m.left, m.top);
  context.lineTo(m.left, height - m.bottom);
  context.lineTo(width - m.right, height - m.bottom);
  context.stroke();
  for (let i = 0; i <= 4; i++) {
    context.textAlign = "right";
    context.fillText(String(+(yMax * i / 4).toPrecision(3)), m.left - 4, y(yMax * i / 4) + 4);
    context.textAlign = "center";
    context.fillText(String(+(xMax * i / 4).toPrecision(3)), x(xMax * i / 4), height - m.bottom + 14);
  }
  context.fillText(xLabel, (m.left + width - m.right) / 2, height - 4);
  context.save();
  context.translate(11, (m.top + height - m.bottom) / 2);
  context.rotate(-Math.PI / 2);
  context.fillText(yLabel, 0, 0);
  context.restore();
  return { context, x, y };
}

// series: [{points: [[x, y], ...], colour, line: bool}]; reference: {y, label} or null.
export function plotXY(canvas, series, { xLabel, yLabel, reference = null }) {
  const all = series.flatMap((s) => s.points);
  const xMax = niceMax(Math.max(1, ...all.map((p) => p[0])));
  const yMax = niceMax(Math.max(reference ? reference.y * 1.15 : 1, ...all.map((p) => p[1])));
  const { context, x, y } = frame(canvas, xMax, yMax, xLabel, yLabel);
  if (reference) {
    context.strokeStyle = "#b42318";
    context.setLineDash([5, 4]);
    context.beginPath();
    context.moveTo(x(0), y(reference.y));
    context.lineTo(x(xMax), y(reference.y));
    context.stroke();
    context.setLineDash([]);
    context.fillStyle = "#b42318";
    context.textAlign = "right";
    context.fillText(reference.label, x(xMax), y(reference.y) - 4);
  }
  for (const s of series) {
    context.strokeStyle = context.fillStyle = s.colour || "#2563eb";
    if (s.line) {
      context.beginPath();
      s.points.forEach(([px, py], i) => (i ? context.lineTo(x(px), y(py)) : context.moveTo(x(px), y(py))));
      context.stroke();
    } else {
      for (const [px, py] of s.points) {
        context.beginPath();
        context.arc(x(px), y(py), 3.5, 0, 2 * Math.PI);
        context.fill();
      }
    }
  }
}

// bars: [[label, count], ...]
export function plotBars(canvas, bars, { xLabel, yLabel }) {
  const yMax = niceMax(Math.max(1, ...bars.map((b) => b[1])));
  const { context, y } = frame(canvas, 1, yMax, "", yLabel);
  const { width, height } = { width: canvas.clientWidth, height: canvas.clientHeight };
  const left = 48, right = 10, slot = (width - left - right) / Math.max(1, bars.length);
  context.clearRect(left + 1, height - 33, width, 20);
  context.textAlign = "center";
  bars.forEach(([label, count], i) => {
    context.fillStyle = "#2563eb";
    context.fillRect(left + i * slot + slot * 0.15, y(count), slot * 0.7, y(0) - y(count));
    context.fillStyle = "#475467";
    context.fillText(String(label), left + (i + 0.5) * slot, height - 20);
    context.fillText(String(count), left + (i + 0.5) * slot, y(count) - 3);
  });
  context.fillText(xLabel, (left + width - right) / 2, height - 4);
}
