// A shipradar subscriber in Node.js, written from docs/protocol.md and the shipped JSON
// Schemas only: a second reference decoder outside Python (issue 39, item 10).
//
//   npm ci
//   node subscriber.mjs tcp://127.0.0.1:5556 [--schemas DIR] [--idle-s 30]
//
// It subscribes to every topic of a live `shipradar run --publish ENDPOINT`, validates every
// message against the JSON Schemas (sim/stream/contract/, draft-07, ajv in strict mode with
// the x-* annotations declared: protocol.md section 10), decodes the msgpack extension
// columns (section 3: copied before they are viewed, the ext data sits at any offset),
// places the plots in the local frame with the antenna state that `meta` carries at the
// start of each scan (sections 4.0, 4.1), stops on `end` (section 4.3) and prints one JSON
// line: messages per topic, schema failures, and the plots' range and azimuth errors against
// `truth` normalised by their sigma (section 4.2: N(0, 1)), and the range rate unfolded with
// the bank's reference and span (section 4.2). Exit status 0 when it heard `end` and every
// message was valid, 1 otherwise, 2 on bad arguments.

import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { Decoder, ExtensionCodec } from '@msgpack/msgpack';
import AjvModule from 'ajv';
import * as zmq from 'zeromq';

const Ajv = AjvModule.default ?? AjvModule;

// section 10: the annotations the schemas carry besides JSON Schema's own keywords
const ANNOTATIONS = ['x-topic', 'x-unit', 'x-dtype', 'x-typestr', 'x-length', 'x-encoding'];
// section 4.0: WGS-84 and the 4/3 effective earth
const A_WGS84 = 6378137.0;
const F_WGS84 = 1.0 / 298.257223563;
const K_EFFECTIVE = 4.0 / 3.0;

// ------------------------------------------------------------------ arguments
function parseArgs(argv) {
  const here = path.dirname(fileURLToPath(import.meta.url));
  const out = { endpoint: null, schemas: path.resolve(here, '../../sim/stream/contract'),
                idleS: 30 };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a === '--schemas') out.schemas = argv[++i];
    else if (a === '--idle-s') out.idleS = Number(argv[++i]);
    else if (a.startsWith('--')) throw new Error(`unknown option ${a}`);
    else out.endpoint = a;
  }
  if (!out.endpoint) throw new Error('usage: node subscriber.mjs ENDPOINT [--schemas DIR] [--idle-s S]');
  if (!(out.idleS > 0)) throw new Error(`--idle-s must be > 0, got ${out.idleS}`);
  return out;
}

// ------------------------------------------------------------------ section 3: columns
const TYPED = {
  '<f8': Float64Array, '<f4': Float32Array,
  '<i8': BigInt64Array, '<i4': Int32Array, '<i2': Int16Array, '|i1': Int8Array,
  '<u8': BigUint64Array, '<u4': Uint32Array, '<u2': Uint16Array, '|u1': Uint8Array,
  '|b1': Uint8Array,
};

/** A decoded array column: its wire type string, shape and elements (a typed array). */
class Column {
  constructor(typestr, shape, values) {
    this.typestr = typestr;
    this.shape = shape;
    this.values = values;
  }
  get length() { return this.shape.length ? this.shape[0] : 1; }
  /** Element i of a 1-D column as a JS number (int64 through Number: exact below 2^53). */
  at(i) {
    const v = this.values[i];
    return typeof v === 'bigint' ? Number(v) : v;
  }
}

const stats = { columns: 0, unaligned: 0 };

/** msgpack ext type 1 -> Column (section 3). ``data`` is a view into the received message,
 *  at whatever offset msgpack put it: the element bytes are copied into a fresh (aligned)
 *  buffer before a typed array views them. */
function decodeColumn(data) {
  const ndim = data[0];
  const lts = data[1];
  const typestr = String.fromCharCode(...data.subarray(2, 2 + lts));
  const Typed = TYPED[typestr];
  if (Typed === undefined) throw new Error(`column type ${typestr} not handled`);
  const pos = Math.ceil((2 + lts) / 8) * 8;
  const view = new DataView(data.buffer, data.byteOffset, data.byteLength);
  const shape = [];
  let count = 1;
  for (let k = 0; k < ndim; k++) {
    const n = Number(view.getBigUint64(pos + 8 * k, true));
    shape.push(n);
    count *= n;
  }
  const start = pos + 8 * ndim;
  stats.columns += 1;
  if ((data.byteOffset + start) % Typed.BYTES_PER_ELEMENT !== 0) stats.unaligned += 1;
  // copied into a fresh buffer, which starts at offset 0, aligned for any element type (a
  // Node.js Buffer's slice() is a view on the received bytes, not a copy: not used here)
  const bytes = new Uint8Array(count * Typed.BYTES_PER_ELEMENT);
  bytes.set(data.subarray(start, start + bytes.length));
  return new Column(typestr, shape, new Typed(bytes.buffer, 0, count));
}

const extensionCodec = new ExtensionCodec();
extensionCodec.register({
  type: 1,
  encode: () => null,
  decode: (data) => decodeColumn(data),
});
const decoder = new Decoder({ extensionCodec });

// ------------------------------------------------------------------ section 10: JSON form
/** The JSON form a schema describes: columns as (nested) arrays, NaN and ±inf as null,
 *  int64 as numbers (exact below 2^53, section 10), bool columns as booleans. */
function jsonForm(value) {
  if (value instanceof Column) {
    const flat = Array.from(value.values, (x) => {
      if (value.typestr === '|b1') return x !== 0;
      if (typeof x === 'bigint') return Number(x);
      return Number.isFinite(x) ? x : null;
    });
    return nest(flat, value.shape);
  }
  if (typeof value === 'number') return Number.isFinite(value) ? value : null;
  if (Array.isArray(value)) return value.map(jsonForm);
  if (value instanceof Uint8Array) return Buffer.from(value).toString('utf8');
  if (value !== null && typeof value === 'object') {
    const out = {};
    for (const [k, v] of Object.entries(value)) out[k] = jsonForm(v);
    return out;
  }
  return value;
}

function nest(flat, shape) {
  if (shape.length <= 1) return flat;
  const step = flat.length / shape[0];
  const out = [];
  for (let i = 0; i < shape[0]; i++) out.push(nest(flat.slice(i * step, (i + 1) * step), shape.slice(1)));
  return out;
}

function loadValidators(dir) {
  const ajv = new Ajv({ strict: true, allErrors: true });
  ajv.addVocabulary(ANNOTATIONS);
  const validators = {};
  for (const file of fs.readdirSync(dir).filter((f) => f.endsWith('.schema.json')).sort()) {
    const schema = JSON.parse(fs.readFileSync(path.join(dir, file), 'utf8'));
    if (schema.$schema !== 'http://json-schema.org/draft-07/schema#') {
      throw new Error(`${file}: dialect ${schema.$schema}, expected draft-07`);
    }
    // keyed by the topic each declares (x-topic) and, for a topic of several payloads
    // (truth), by the const of its `kind`: the discriminator of section 10
    const kind = schema.properties?.kind?.const;
    validators[kind === undefined ? schema['x-topic'] : `${schema['x-topic']}[${kind}]`] =
      ajv.compile(schema);
  }
  return validators;
}


// ------------------------------------------------------------------ section 4.0: the frame
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                         a[0] * b[1] - a[1] * b[0]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const add = (...vs) => vs.reduce((s, v) => [s[0] + v[0], s[1] + v[1], s[2] + v[2]], [0, 0, 0]);
const norm = (a) => Math.hypot(a[0], a[1], a[2]);
const wrapPi = (x) => ((((x + Math.PI) % (2 * Math.PI)) + 2 * Math.PI) % (2 * Math.PI)) - Math.PI;

/** The local frame of `meta.origin` (section 4.0): east/north on the plane tangent at the
 *  origin projected onto the sphere of the Gaussian radius √(M N) there, up the height above
 *  the sea; azimuths from true north at the antenna; slant ranges over the 4/3 earth. */
class Frame {
  constructor(latDeg, lonDeg) {
    const lat = (latDeg * Math.PI) / 180;
    const lon = (lonDeg * Math.PI) / 180;
    const e2 = F_WGS84 * (2 - F_WGS84);
    this.radius = (A_WGS84 * Math.sqrt(1 - e2)) / (1 - e2 * Math.sin(lat) ** 2);
    this.up0 = [Math.cos(lat) * Math.cos(lon), Math.cos(lat) * Math.sin(lon), Math.sin(lat)];
    this.east0 = [-Math.sin(lon), Math.cos(lon), 0];
    this.north0 = cross(this.up0, this.east0);
  }
  unit(east, north) {
    const t = add(scale(this.up0, this.radius), scale(this.east0, east), scale(this.north0, north));
    return scale(t, 1 / norm(t));
  }
  static northEast(u) {
    const h = Math.hypot(u[0], u[1]);
    const east = [-u[1] / h, u[0] / h, 0];
    return [cross(u, east), east];
  }
  /** Slant range [m] and azimuth [rad] of local point `target` from local `antenna`. */
  toPlot(antenna, target) {
    const ua = this.unit(antenna[0], antenna[1]);
    const ut = this.unit(target[0], target[1]);
    const [north, east] = Frame.northEast(ua);
    const chord = add(ut, scale(ua, -1));
    let az = Math.atan2(dot(chord, east), dot(chord, north));
    if (az < 0) az += 2 * Math.PI;
    const ground = this.radius * Math.atan2(norm(cross(ua, ut)), dot(ua, ut));
    const ae = K_EFFECTIVE * this.radius;
    const r1 = ae + antenna[2];
    const r2 = ae + target[2];
    const slant = Math.sqrt((r2 - r1) ** 2 + 4 * r1 * r2 * Math.sin((0.5 * ground) / ae) ** 2);
    return [slant, az];
  }
  /** Local east/north/up of a plot for an assumed height `up` (a 2-D radar measures none). */
  place(antenna, range, azimuth, up) {
    const ae = K_EFFECTIVE * this.radius;
    const r1 = ae + antenna[2];
    const r2 = ae + up;
    const s2 = Math.min(1, Math.max(0, (range ** 2 - (r2 - r1) ** 2) / (4 * r1 * r2)));
    const ground = 2 * ae * Math.asin(Math.sqrt(s2));
    const ua = this.unit(antenna[0], antenna[1]);
    const [north, east] = Frame.northEast(ua);
    const d = ground / this.radius;
    const heading = add(scale(north, Math.cos(azimuth)), scale(east, Math.sin(azimuth)));
    const ut = add(scale(ua, Math.cos(d)), scale(heading, Math.sin(d)));
    const t = scale(ut, this.radius / dot(ut, this.up0));
    return [dot(t, this.east0), dot(t, this.north0), up];
  }
}

// ------------------------------------------------------------------ the subscriber
class Subscriber {
  constructor(validators) {
    this.validators = validators;
    this.counts = {};
    this.failures = 0;
    this.failureExamples = [];
    this.ended = false;
    this.frame = null;
    this.state = new Map(); // sensor -> {t, position, velocity, source}
    this.span = new Map(); // sensor -> meta.range_rate_span_mps
    this.plots = new Map(); // `${sensor}/${plot_id}` -> placed plot
    this.truthPlots = new Map();
    this.truthStates = new Map(); // time_s -> states
    this.placedWith = {};
  }

  handle(topicBuf, bodyBuf) {
    const topic = Buffer.from(topicBuf).toString('ascii');
    this.counts[topic] = (this.counts[topic] ?? 0) + 1;
    let msg;
    try {
      msg = decoder.decode(bodyBuf);
    } catch (e) {
      this.fail(topic, `undecodable: ${e.message}`);
      return;
    }
    // the topic's schema; `truth` told apart by `kind` (section 10)
    const byKind = `${topic}[${msg.kind}]`;
    const name = typeof msg.kind === 'string' && byKind in this.validators ? byKind : topic;
    const validate = this.validators[name];
    if (validate === undefined) {
      this.fail(topic, `no schema ${name}`);
    } else if (!validate(jsonForm(msg))) {
      this.fail(topic, ajvErrors(validate.errors));
    }
    if (msg.v !== 1 && msg.v !== 2) {
      // section 2: refuse a version it does not know (the schemas' `v` enum says so too)
      this.fail(topic, `unsupported schema version ${msg.v}`);
      return;
    }
    if (topic === 'meta') this.onMeta(msg);
    else if (topic === 'eos') this.onState(msg, 'eos');
    else if (topic === 'plots') this.onPlots(msg);
    else if (topic === 'truth') this.onTruth(msg);
    else if (topic === 'end') this.ended = true;
  }

  fail(topic, why) {
    this.failures += 1;
    if (this.failureExamples.length < 5) this.failureExamples.push(`${topic}: ${why}`);
  }

  onMeta(msg) {
    if (this.frame === null) this.frame = new Frame(msg.origin.lat_deg, msg.origin.lon_deg);
    if (msg.range_rate_span_mps !== undefined) this.span.set(msg.sensor, msg.range_rate_span_mps);
    this.onState(msg, 'meta');
  }

  /** The latest antenna state (section 4.1: meta's at a scan's start, eos's at its end). */
  onState(msg, source) {
    if (msg.position === undefined) return;
    const old = this.state.get(msg.sensor);
    if (old !== undefined && old.t > msg.t) return;
    const p = msg.position;
    this.state.set(msg.sensor, { t: msg.t, position: [p.east_m, p.north_m, p.up_m],
                                 velocity: msg.velocity_enu_mps, source });
  }

  onPlots(msg) {
    const s = this.state.get(msg.sensor);
    if (s === undefined || this.frame === null) return; // a tracker would hold them
    const n = msg.plot_id.length;
    this.placedWith[s.source] = (this.placedWith[s.source] ?? 0) + n;
    const col = (k, i) => (msg[k] === undefined ? NaN : msg[k].at(i));
    for (let i = 0; i < n; i++) {
      const t = msg.time_s.at(i);
      // the antenna at the plot's time: position + velocity × (time_s − t) (section 4.1)
      const antenna = add(s.position, scale(s.velocity, t - s.t));
      this.plots.set(`${msg.sensor}/${msg.plot_id.at(i)}`, {
        sensor: msg.sensor, time_s: t, antenna,
        range_m: col('range_m', i), azimuth_rad: col('azimuth_rad', i),
        sigma_range_m: col('sigma_range_m', i), sigma_azimuth_rad: col('sigma_azimuth_rad', i),
        range_rate_mps: col('range_rate_mps', i),
        sigma_range_rate_mps: col('sigma_range_rate_mps', i),
        range_rate_reference_mps: col('range_rate_reference_mps', i),
        // placed at sea level, as a tracker with no height would (section 4.0)
        placed: this.frame.place(antenna, col('range_m', i), col('azimuth_rad', i), 0),
      });
    }
  }

  onTruth(msg) {
    if (msg.kind === 'plots') {
      for (let i = 0; i < msg.plot_id.length; i++) {
        const a = msg.contrib_offsets.at(i);
        const b = msg.contrib_offsets.at(i + 1);
        this.truthPlots.set(`${msg.sensor}/${msg.plot_id.at(i)}`, {
          origin: msg.origin.at(i), target: msg.target.at(i), contributors: b - a,
          true_range_rate_mps: msg.true_range_rate_mps === undefined
            ? NaN : msg.true_range_rate_mps.at(i),
        });
      }
    } else {
      const keys = ['east_m', 'north_m', 'up_m', 'v_east_mps', 'v_north_mps', 'v_up_mps'];
      const st = { active: msg.active };
      for (const k of keys) st[k] = msg[k];
      this.truthStates.set(msg.time_s, st);
    }
  }

  /** Target `target`'s local position at `t`: cubic Hermite between the end-of-scan states
   *  around `t`; null when either is missing or inactive. */
  truthAt(target, t) {
    const times = [...this.truthStates.keys()].sort((x, y) => x - y);
    let k = times.findIndex((x) => x >= t);
    if (k <= 0) return null;
    const s0 = this.truthStates.get(times[k - 1]);
    const s1 = this.truthStates.get(times[k]);
    if (!s0.active.at(target) || !s1.active.at(target)) return null;
    const h = times[k] - times[k - 1];
    const x = (t - times[k - 1]) / h;
    const get = (s, keys) => keys.map((c) => s[c].at(target));
    const p0 = get(s0, ['east_m', 'north_m', 'up_m']);
    const p1 = get(s1, ['east_m', 'north_m', 'up_m']);
    const v0 = get(s0, ['v_east_mps', 'v_north_mps', 'v_up_mps']);
    const v1 = get(s1, ['v_east_mps', 'v_north_mps', 'v_up_mps']);
    const h00 = 2 * x ** 3 - 3 * x ** 2 + 1;
    const h10 = x ** 3 - 2 * x ** 2 + x;
    const h01 = -2 * x ** 3 + 3 * x ** 2;
    const h11 = x ** 3 - x ** 2;
    return add(scale(p0, h00), scale(v0, h10 * h), scale(p1, h01), scale(v1, h11 * h));
  }

  summary() {
    const zr = [];
    const za = [];
    const seaLevel = [];
    let roundtrip = 0;
    const rr = { inside: 0, max_error_inside_mps: 0, unfolded: 0, max_error_unfolded_mps: 0,
                 half_filter_mps: 0, outside_interval: 0 };
    for (const [key, plot] of this.plots) {
      const truth = this.truthPlots.get(key);
      if (truth === undefined || truth.origin !== 0 || truth.contributors !== 1) continue;
      const pos = this.truthAt(truth.target, plot.time_s);
      if (pos === null) continue;
      const [r, az] = this.frame.toPlot(plot.antenna, pos);
      zr.push((plot.range_m - r) / plot.sigma_range_m);
      za.push(wrapPi(plot.azimuth_rad - az) / plot.sigma_azimuth_rad);
      if (pos[2] < 1) seaLevel.push(Math.hypot(plot.placed[0] - pos[0], plot.placed[1] - pos[1]));
      // placed at the truth's height and measured back: the frame's round trip
      const where = this.frame.place(plot.antenna, plot.range_m, plot.azimuth_rad, pos[2]);
      const [rb, ab] = this.frame.toPlot(plot.antenna, where);
      roundtrip = Math.max(roundtrip, Math.abs(rb - plot.range_m),
                           1e6 * Math.abs(wrapPi(ab - plot.azimuth_rad)));
      // section 4.2: unfolding with the bank's reference and span
      const span = this.span.get(plot.sensor);
      const v = truth.true_range_rate_mps;
      if (span === undefined || !Number.isFinite(plot.range_rate_mps) || !Number.isFinite(v)) continue;
      const q = Math.sqrt(12) * plot.sigma_range_rate_mps; // the filter spacing S / N
      rr.half_filter_mps = Math.max(rr.half_filter_mps, q / 2);
      const ref = plot.range_rate_reference_mps;
      if (!(plot.range_rate_mps > ref - span / 2 - 1e-9 && plot.range_rate_mps <= ref + span / 2 + 1e-9)) {
        rr.outside_interval += 1;
      }
      if (Math.abs(v - ref) < span / 2 - q / 2) {
        rr.inside += 1;
        rr.max_error_inside_mps = Math.max(rr.max_error_inside_mps, Math.abs(plot.range_rate_mps - v));
      } else {
        // a tracker's prediction a quarter span off the truth picks the fold
        const pred = v + span / 4;
        const k = Math.round((pred - plot.range_rate_mps) / span);
        rr.unfolded += 1;
        rr.max_error_unfolded_mps = Math.max(rr.max_error_unfolded_mps,
                                             Math.abs(plot.range_rate_mps + k * span - v));
      }
    }
    return {
      counts: this.counts,
      messages: Object.values(this.counts).reduce((a, b) => a + b, 0),
      schema_failures: this.failures,
      failure_examples: this.failureExamples,
      ended: this.ended,
      columns: stats.columns,
      columns_unaligned: stats.unaligned,
      plots: this.plots.size,
      placed_with: this.placedWith,
      z_range: meanStd(zr),
      z_azimuth: meanStd(za),
      roundtrip_max: roundtrip,
      sea_level_placement_error_m: meanStd(seaLevel),
      range_rate: rr,
    };
  }
}

function meanStd(xs) {
  const n = xs.length;
  if (n === 0) return { n, mean: null, std: null };
  const mean = xs.reduce((a, b) => a + b, 0) / n;
  const v = n > 1 ? xs.reduce((a, b) => a + (b - mean) ** 2, 0) / (n - 1) : 0;
  return { n, mean, std: Math.sqrt(v) };
}

function ajvErrors(errors) {
  return (errors ?? []).slice(0, 3).map((e) => `${e.instancePath || '/'} ${e.message}`).join('; ');
}

// ------------------------------------------------------------------ main
async function main() {
  let args;
  try {
    args = parseArgs(process.argv.slice(2));
  } catch (e) {
    process.stderr.write(`error: ${e.message}\n`);
    return 2;
  }
  const validators = loadValidators(args.schemas);
  const sub = new Subscriber(validators);
  const sock = new zmq.Subscriber({ linger: 0, receiveTimeout: Math.round(args.idleS * 1000) });
  sock.connect(args.endpoint);
  sock.subscribe(); // every topic: meta, plots, eos, truth, end (section 1)
  try {
    while (!sub.ended) {
      let frames;
      try {
        frames = await sock.receive();
      } catch (e) {
        if (e.code === 'EAGAIN') {
          process.stderr.write(`error: nothing received for ${args.idleS} s, no end\n`);
          break;
        }
        throw e;
      }
      if (frames.length !== 2) {
        sub.fail('?', `${frames.length} frames, expected 2`);
        continue;
      }
      sub.handle(frames[0], frames[1]);
    }
  } finally {
    sock.close();
  }
  process.stdout.write(`${JSON.stringify(sub.summary())}\n`);
  return sub.ended && sub.failures === 0 ? 0 : 1;
}

process.exitCode = await main();
