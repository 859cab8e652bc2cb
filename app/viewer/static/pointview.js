// A small WebGL point renderer: orbit (drag), zoom (wheel), points coloured by a value in
// [0, 1] (a negative value: grey); and 2D thumbnails of the same clouds for grids (no WebGL
// context per card).

const COLOUR_STOPS = [ // dark blue -> teal -> green -> yellow: low to high heat kept at a point
  [0.27, 0.00, 0.33], [0.23, 0.32, 0.55], [0.13, 0.57, 0.55], [0.37, 0.79, 0.38], [0.99, 0.91, 0.14],
];

export function colour(t) {
  const x = Math.min(Math.max(t, 0), 1) * (COLOUR_STOPS.length - 1);
  const i = Math.min(Math.floor(x), COLOUR_STOPS.length - 2);
  const f = x - i;
  return COLOUR_STOPS[i].map((c, j) => c + (COLOUR_STOPS[i + 1][j] - c) * f);
}

const GLSL_STOPS = COLOUR_STOPS.map((c) => `vec3(${c.map((v) => v.toFixed(3)).join(",")})`);

const VERTEX_SHADER = `
attribute vec3 position;
attribute float value;
uniform mat4 matrix;
uniform float pointSize;
varying float v;
void main() {
  gl_Position = matrix * vec4(position, 1.0);
  gl_PointSize = pointSize;
  v = value;
}`;

const FRAGMENT_SHADER = `
precision mediump float;
varying float v;
vec3 colourOf(float t) {
  if (t < 0.0) return vec3(0.70, 0.73, 0.78); // no value: a reference drawn grey
  float x = clamp(t, 0.0, 1.0) * 4.0;
  if (x < 1.0) return mix(${GLSL_STOPS[0]}, ${GLSL_STOPS[1]}, x);
  if (x < 2.0) return mix(${GLSL_STOPS[1]}, ${GLSL_STOPS[2]}, x - 1.0);
  if (x < 3.0) return mix(${GLSL_STOPS[2]}, ${GLSL_STOPS[3]}, x - 2.0);
  return mix(${GLSL_STOPS[3]}, ${GLSL_STOPS[4]}, x - 3.0);
}
void main() {
  vec2 c = gl_PointCoord * 2.0 - 1.0;
  if (dot(c, c) > 1.0) discard;
  gl_FragColor = vec4(colourOf(v), 1.0);
}`;

// Values of one HKS time scaled to [0, 1] by their 2nd and 98th percentiles.
export function scaledColumn(preview, timeIndex) {
  const s = preview.times.length;
  const values = new Float32Array(preview.n);
  for (let i = 0; i < preview.n; i++) values[i] = preview.logHks[i * s + timeIndex];
  const sorted = Float32Array.from(values).sort();
  const low = sorted[Math.floor(0.02 * (sorted.length - 1))];
  const high = sorted[Math.ceil(0.98 * (sorted.length - 1))];
  const span = high - low > 1e-6 ? high - low : 1;
  return values.map((value) => (value - low) / span);
}

function radiusOf(points) {
  let radius = 1e-6;
  for (let i = 0; i < points.length; i += 3) {
    radius = Math.max(radius, Math.hypot(points[i], points[i + 1], points[i + 2]));
  }
  return radius;
}

// Column-major 4x4: perspective * translate(0, 0, -distance) * rotateX(pitch) * rotateY(yaw).
function viewMatrix(aspect, yaw, pitch, distance, radius) {
  const f = 1 / Math.tan(Math.PI / 8), near = Math.max(distance - 2 * radius, 1e-3);
  const far = distance + 2 * radius;
  const cy = Math.cos(yaw), sy = Math.sin(yaw), cp = Math.cos(pitch), sp = Math.sin(pitch);
  // Rotation rows of rotateX(pitch) * rotateY(yaw).
  const r = [
    [cy, 0, sy],
    [sp * sy, cp, -sp * cy],
    [-cp * sy, sp, cp * cy],
  ];
  const a = (far + near) / (near - far), b = (2 * far * near) / (near - far);
  const m = new Float32Array(16);
  for (let col = 0; col < 3; col++) {
    m[col * 4 + 0] = (f / aspect) * r[0][col];
    m[col * 4 + 1] = f * r[1][col];
    m[col * 4 + 2] = a * r[2][col];
    m[col * 4 + 3] = -r[2][col];
  }
  m[14] = -a * distance + b;
  m[15] = distance;
  return m;
}

export class PointView {
  constructor(canvas) {
    this.canvas = canvas;
    const gl = canvas.getContext("webgl", { antialias: true, preserveDrawingBuffer: true });
    if (!gl) throw new Error("WebGL is not available in this browser");
    this.gl = gl;
    this.program = this.#program();
    this.positionBuffer = gl.createBuffer();
    this.valueBuffer = gl.createBuffer();
    this.count = 0;
    this.yaw = 0.7;
    this.pitch = 0.45;
    this.zoom = 1;
    this.radius = 1;
    this.pending = false;
    this.#controls();
  }

  #program() {
    const gl = this.gl;
    const shader = (type, source) => {
      const s = gl.createShader(type);
      gl.shaderSource(s, source);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(s));
      return s;
    };
    const program = gl.createProgram();
    gl.attachShader(program, shader(gl.VERTEX_SHADER, VERTEX_SHADER));
    gl.attachShader(program, shader(gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
    gl.linkProgram(program);
    return program;
  }

  #controls() {
    let last = null;
    this.canvas.addEventListener("pointerdown", (event) => {
      last = [event.clientX, event.clientY];
      this.canvas.setPointerCapture(event.pointerId);
    });
    this.canvas.addEventListener("pointermove", (event) => {
      if (!last) return;
      this.yaw += (event.clientX - last[0]) * 0.01;
      this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch + (event.clientY - last[1]) * 0.01));
      last = [event.clientX, event.clientY];
      this.draw();
    });
    this.canvas.addEventListener("pointerup", () => { last = null; });
    this.canvas.addEventListener("wheel", (event) => {
      event.preventDefault();
      this.zoom = Math.max(0.3, Math.min(8, this.zoom * Math.exp(-event.deltaY * 0.001)));
      this.draw();
    }, { passive: false });
  }

  // points: Float32Array (n*3); values: Float32Array (n) in [0, 1].
  setCloud(points, values) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.positionBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, points, gl.STATIC_DRAW);
    this.count = points.length / 3;
    this.radius = radiusOf(points);
    this.setValues(values);
  }

  setValues(values) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.valueBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, values, gl.DYNAMIC_DRAW);
    this.draw();
  }

  draw() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.#render();
    });
  }

  #render() {
    const gl = this.gl, canvas = this.canvas;
    const ratio = window.devicePixelRatio || 1;
    const width = Math.max(1, Math.round(canvas.clientWidth * ratio));
    const height = Math.max(1, Math.round(canvas.clientHeight * ratio));
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
    }
    gl.viewport(0, 0, width, height);
    gl.clearColor(1, 1, 1, 1);
    gl.enable(gl.DEPTH_TEST);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.useProgram(this.program);
    const distance = (this.radius / Math.sin(Math.PI / 8)) * 1.05 / this.zoom;
    const matrix = viewMatrix(width / height, this.yaw, this.pitch, distance, this.radius);
    gl.uniformMatrix4fv(gl.getUniformLocation(this.program, "matrix"), false, matrix);
    gl.uniform1f(gl.getUniformLocation(this.program, "pointSize"), 5 * ratio);
    const bind = (buffer, name, size) => {
      const location = gl.getAttribLocation(this.program, name);
      gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
      gl.enableVertexAttribArray(location);
      gl.vertexAttribPointer(location, size, gl.FLOAT, false, 0, 0);
    };
    bind(this.positionBuffer, "position", 3);
    bind(this.valueBuffer, "value", 1);
    gl.drawArrays(gl.POINTS, 0, this.count);
    canvas.dataset.rendered = String(performance.now());
  }
}

// A fixed-angle 2D drawing of a preview, far points first.
export function drawThumbnail(canvas, preview, timeIndex) {
  const ratio = window.devicePixelRatio || 1;
  canvas.width = Math.round(canvas.clientWidth * ratio) || 170;
  canvas.height = Math.round(canvas.clientHeight * ratio) || 140;
  const context = canvas.getContext("2d");
  const values = scaledColumn(preview, timeIndex);
  const radius = radiusOf(preview.points);
  const cy = Math.cos(0.7), sy = Math.sin(0.7), cp = Math.cos(0.45), sp = Math.sin(0.45);
  const projected = [];
  for (let i = 0; i < preview.n; i++) {
    const x = preview.points[3 * i], y = preview.points[3 * i + 1], z = preview.points[3 * i + 2];
    const px = cy * x + sy * z;
    const py = sp * sy * x + cp * y - sp * cy * z;
    const depth = -cp * sy * x + sp * y + cp * cy * z;
    projected.push([px, py, depth, values[i]]);
  }
  projected.sort((a, b) => a[2] - b[2]);
  const scale = (0.45 * Math.min(canvas.width, canvas.height)) / radius;
  const size = Math.max(2, 2 * ratio);
  for (const [px, py, , value] of projected) {
    const [r, g, b] = colour(value);
    context.fillStyle = `rgb(${r * 255 | 0},${g * 255 | 0},${b * 255 | 0})`;
    context.fillRect(canvas.width / 2 + px * scale, canvas.height / 2 - py * scale, size, size);
  }
}
