/* shipradar._frames: the stream's per-message byte work in one call per revolution.
 *
 * Two functions, each the compiled twin of a Python reference that the tests compare it
 * with byte for byte:
 *
 *   encode_slices(prefix, fixed, which, times, cols, ext_type, max_body) -> list[bytes]
 *       the bodies of sim.protocol.encode_slices (msgpack maps whose columns are slices of
 *       shared arrays, as numpy-ndarray extensions);
 *   frame_records(records, seq, max_record, offset) -> (bytes, ends, raw, done) or None
 *       the format-2 records of sim.recording.Recorder.write_many for [topic, body]
 *       messages (sync marker, header with sequence number and CRC-32s, payload).
 *
 * Every multi-byte field is written byte by byte in its stated order (msgpack's big-endian,
 * the recording's little-endian), so the bytes do not depend on the host's order.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <dlfcn.h>
#include <stdint.h>
#include <string.h>

/* ------------------------------------------------------------------ CRC-32 (zlib's) */
static uint32_t crc_table[8][256];

static void crc_init(void)
{
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++)
            c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        crc_table[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = crc_table[0][i];
        for (int t = 1; t < 8; t++) {
            c = crc_table[0][c & 0xFF] ^ (c >> 8);
            crc_table[t][i] = c;
        }
    }
}

/* zlib's own crc32 (the library Python's zlib module is built on: faster than the table
   below, which stands in when the shared library cannot be found), looked up at import */
typedef unsigned long (*zlib_crc32_fn)(unsigned long, const unsigned char *, unsigned int);
static zlib_crc32_fn zlib_crc32;

static void zlib_init(void)
{
    const char *names[] = {"libz.so.1", "libz.so", "libz.1.dylib", NULL};
    for (int i = 0; names[i] != NULL && zlib_crc32 == NULL; i++) {
        void *lib = dlopen(names[i], RTLD_NOW | RTLD_LOCAL);
        if (lib != NULL)
            zlib_crc32 = (zlib_crc32_fn)dlsym(lib, "crc32");
    }
}

static uint32_t crc32_table(uint32_t crc, const unsigned char *p, size_t n);

/* zlib.crc32(data, crc): the CRC-32 of the bytes so far (crc) continued over data */
static uint32_t crc32_update(uint32_t crc, const unsigned char *p, size_t n)
{
    if (zlib_crc32 == NULL)
        return crc32_table(crc, p, n);
    unsigned long c = crc;
    while (n > 0) { /* zlib takes unsigned int lengths */
        unsigned int chunk = n > 0x40000000u ? 0x40000000u : (unsigned int)n;
        c = zlib_crc32(c, p, chunk);
        p += chunk;
        n -= chunk;
    }
    return (uint32_t)c;
}

static uint32_t crc32_table(uint32_t crc, const unsigned char *p, size_t n)
{
    uint32_t c = ~crc;
    while (n && ((uintptr_t)p & 7)) {
        c = crc_table[0][(c ^ *p++) & 0xFF] ^ (c >> 8);
        n--;
    }
    while (n >= 8) { /* slicing by 8 */
        uint32_t lo = c ^ ((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
                           (uint32_t)p[3] << 24);
        uint32_t hi = (uint32_t)p[4] | (uint32_t)p[5] << 8 | (uint32_t)p[6] << 16 |
                      (uint32_t)p[7] << 24;
        c = crc_table[7][lo & 0xFF] ^ crc_table[6][(lo >> 8) & 0xFF] ^
            crc_table[5][(lo >> 16) & 0xFF] ^ crc_table[4][lo >> 24] ^
            crc_table[3][hi & 0xFF] ^ crc_table[2][(hi >> 8) & 0xFF] ^
            crc_table[1][(hi >> 16) & 0xFF] ^ crc_table[0][hi >> 24];
        p += 8;
        n -= 8;
    }
    while (n--)
        c = crc_table[0][(c ^ *p++) & 0xFF] ^ (c >> 8);
    return ~c;
}

static PyObject *py_crc32(PyObject *self, PyObject *args)
{
    Py_buffer b;
    unsigned long crc = 0;
    int table = 0;
    if (!PyArg_ParseTuple(args, "y*|kp", &b, &crc, &table))
        return NULL;
    uint32_t c = (table ? crc32_table : crc32_update)((uint32_t)crc, b.buf, (size_t)b.len);
    PyBuffer_Release(&b);
    return PyLong_FromUnsignedLong(c);
}

static PyObject *py_uses_zlib(PyObject *self, PyObject *args)
{
    return PyBool_FromLong(zlib_crc32 != NULL);
}

/* ------------------------------------------------------------------ byte writers */
static inline unsigned char *put_le(unsigned char *o, uint64_t v, int n)
{
    for (int i = 0; i < n; i++)
        o[i] = (unsigned char)(v >> (8 * i));
    return o + n;
}

static inline unsigned char *put_be(unsigned char *o, uint64_t v, int n)
{
    for (int i = 0; i < n; i++)
        o[i] = (unsigned char)(v >> (8 * (n - 1 - i)));
    return o + n;
}

static inline uint64_t double_bits(double d)
{
    uint64_t u;
    memcpy(&u, &d, 8);
    return u;
}

/* length of msgpack's ext header for `size` data bytes (the smallest format) */
static inline Py_ssize_t ext_header_len(Py_ssize_t size)
{
    if (size == 1 || size == 2 || size == 4 || size == 8 || size == 16)
        return 2;
    if (size < 0x100)
        return 3;
    if (size < 0x10000)
        return 4;
    return 6;
}

static inline unsigned char *put_ext_header(unsigned char *o, Py_ssize_t size, int type)
{
    switch (size) {
    case 1: *o++ = 0xD4; break;
    case 2: *o++ = 0xD5; break;
    case 4: *o++ = 0xD6; break;
    case 8: *o++ = 0xD7; break;
    case 16: *o++ = 0xD8; break;
    default:
        if (size < 0x100) {
            *o++ = 0xC7;
            o = put_be(o, (uint64_t)size, 1);
        } else if (size < 0x10000) {
            *o++ = 0xC8;
            o = put_be(o, (uint64_t)size, 2);
        } else {
            *o++ = 0xC9;
            o = put_be(o, (uint64_t)size, 4);
        }
    }
    *o++ = (unsigned char)(signed char)type;
    return o;
}

/* ------------------------------------------------------------------ encode_slices */
typedef struct {
    Py_buffer key, head, data, start, stop;
    Py_ssize_t itemsize;
} column;

static void release_columns(column *cols, Py_ssize_t n)
{
    for (Py_ssize_t c = 0; c < n; c++) {
        PyBuffer_Release(&cols[c].key);
        PyBuffer_Release(&cols[c].head);
        PyBuffer_Release(&cols[c].data);
        PyBuffer_Release(&cols[c].start);
        PyBuffer_Release(&cols[c].stop);
    }
}

static PyObject *py_encode_slices(PyObject *self, PyObject *args)
{
    Py_buffer prefix, times, which;
    PyObject *fixed_obj, *cols_obj;
    int ext_type;
    Py_ssize_t max_body;
    if (!PyArg_ParseTuple(args, "y*O!y*y*O!in", &prefix, &PyTuple_Type, &fixed_obj, &which,
                          &times, &PyTuple_Type, &cols_obj, &ext_type, &max_body))
        return NULL;
    PyObject *out = NULL;
    Py_ssize_t n_cols = PyTuple_GET_SIZE(cols_obj), ready = 0;
    Py_ssize_t n_fixed = PyTuple_GET_SIZE(fixed_obj);
    Py_ssize_t n_msg = times.len / (Py_ssize_t)sizeof(double);
    const int64_t *fixed_of = which.buf;
    column *cols = PyMem_Calloc(n_cols ? n_cols : 1, sizeof(column));
    if (cols == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t f = 0; f < n_fixed; f++) {
        if (!PyBytes_Check(PyTuple_GET_ITEM(fixed_obj, f))) {
            PyErr_SetString(PyExc_TypeError, "encode_slices: fixed parts must be bytes");
            goto done;
        }
    }
    if (which.len != n_msg * 8) {
        PyErr_SetString(PyExc_ValueError, "encode_slices: one fixed part index per time");
        goto done;
    }
    for (Py_ssize_t j = 0; j < n_msg; j++) {
        if (fixed_of[j] < 0 || fixed_of[j] >= n_fixed) {
            PyErr_SetString(PyExc_IndexError, "encode_slices: fixed part index out of range");
            goto done;
        }
    }
    for (; ready < n_cols; ready++) {
        column *c = &cols[ready];
        if (!PyArg_ParseTuple(PyTuple_GET_ITEM(cols_obj, ready), "y*y*ny*y*y*", &c->key,
                              &c->head, &c->itemsize, &c->data, &c->start, &c->stop))
            goto done;
        if (c->start.len != n_msg * 8 || c->stop.len != n_msg * 8 || c->itemsize <= 0) {
            ready++;
            PyErr_SetString(PyExc_ValueError, "encode_slices: one start and stop per time");
            goto done;
        }
    }
    out = PyList_New(n_msg);
    if (out == NULL)
        goto done;
    const double *t = times.buf;
    for (Py_ssize_t j = 0; j < n_msg; j++) {
        PyObject *fixed = PyTuple_GET_ITEM(fixed_obj, fixed_of[j]);
        Py_ssize_t fixed_len = PyBytes_GET_SIZE(fixed);
        Py_ssize_t size = prefix.len + 9 + fixed_len;
        for (Py_ssize_t k = 0; k < n_cols; k++) {
            column *c = &cols[k];
            int64_t i0 = ((const int64_t *)c->start.buf)[j];
            int64_t i1 = ((const int64_t *)c->stop.buf)[j];
            if (i0 < 0 || i1 < i0 || i1 * c->itemsize > c->data.len) {
                PyErr_SetString(PyExc_IndexError, "encode_slices: slice out of the column");
                Py_CLEAR(out);
                goto done;
            }
            Py_ssize_t data = c->head.len + 8 + (Py_ssize_t)(i1 - i0) * c->itemsize;
            size += c->key.len + ext_header_len(data) + data;
        }
        if (size > max_body) {
            PyErr_Format(PyExc_OverflowError, "%zd", size);
            Py_CLEAR(out);
            goto done;
        }
        PyObject *body = PyBytes_FromStringAndSize(NULL, size);
        if (body == NULL) {
            Py_CLEAR(out);
            goto done;
        }
        unsigned char *o = (unsigned char *)PyBytes_AS_STRING(body);
        memcpy(o, prefix.buf, prefix.len);
        o += prefix.len;
        *o++ = 0xCB;
        o = put_be(o, double_bits(t[j]), 8);
        memcpy(o, PyBytes_AS_STRING(fixed), fixed_len);
        o += fixed_len;
        for (Py_ssize_t k = 0; k < n_cols; k++) {
            column *c = &cols[k];
            int64_t i0 = ((const int64_t *)c->start.buf)[j];
            int64_t i1 = ((const int64_t *)c->stop.buf)[j];
            Py_ssize_t n = (Py_ssize_t)(i1 - i0), bytes = n * c->itemsize;
            memcpy(o, c->key.buf, c->key.len);
            o += c->key.len;
            o = put_ext_header(o, c->head.len + 8 + bytes, ext_type);
            memcpy(o, c->head.buf, c->head.len); /* the array header, then the count */
            o += c->head.len;
            o = put_le(o, (uint64_t)n, 8);
            memcpy(o, (const char *)c->data.buf + i0 * c->itemsize, bytes);
            o += bytes;
        }
        PyList_SET_ITEM(out, j, body);
    }
done:
    if (cols != NULL) {
        release_columns(cols, ready);
        PyMem_Free(cols);
    }
    PyBuffer_Release(&prefix);
    PyBuffer_Release(&which);
    PyBuffer_Release(&times);
    return out;
}

/* ------------------------------------------------------------------ frame_records */
static const unsigned char SYNC[8] = {0xD3, 'Z', 'S', 'R', 'r', 'e', 'c', 0xE1};
#define RECORD_HEADER 32 /* sync 8, mid 20, header CRC 4 */

/* the (t, topic, body) of a record of two bytes frames, or 0 */
static int two_frames(PyObject *rec, double *t, PyObject **topic, PyObject **body)
{
    if (!PyTuple_Check(rec) || PyTuple_GET_SIZE(rec) != 2)
        return 0;
    PyObject *frames = PyTuple_GET_ITEM(rec, 1);
    PyObject *a, *b;
    if (PyList_Check(frames) && PyList_GET_SIZE(frames) == 2) {
        a = PyList_GET_ITEM(frames, 0);
        b = PyList_GET_ITEM(frames, 1);
    } else if (PyTuple_Check(frames) && PyTuple_GET_SIZE(frames) == 2) {
        a = PyTuple_GET_ITEM(frames, 0);
        b = PyTuple_GET_ITEM(frames, 1);
    } else {
        return 0;
    }
    if (!PyBytes_CheckExact(a) || !PyBytes_CheckExact(b))
        return 0;
    PyObject *ts = PyTuple_GET_ITEM(rec, 0);
    if (!PyFloat_Check(ts) && !PyLong_Check(ts))
        return 0;
    *t = PyFloat_AsDouble(ts);
    if (*t == -1.0 && PyErr_Occurred()) {
        PyErr_Clear();
        return 0;
    }
    *topic = a;
    *body = b;
    return 1;
}

typedef struct {
    double t;
    const char *topic, *body;
    Py_ssize_t lt, lb;
} message;

static PyObject *py_frame_records(PyObject *self, PyObject *args)
{
    PyObject *records;
    unsigned long long seq;
    Py_ssize_t max_record, offset;
    if (!PyArg_ParseTuple(args, "O!Knn", &PyList_Type, &records, &seq, &max_record, &offset))
        return NULL;
    Py_ssize_t n = PyList_GET_SIZE(records), done = 0, total = 0;
    message *msg = PyMem_Malloc((n ? n : 1) * sizeof(message));
    if (msg == NULL)
        return PyErr_NoMemory();
    for (; done < n; done++) {
        PyObject *topic, *body;
        message *m = &msg[done];
        if (!two_frames(PyList_GET_ITEM(records, done), &m->t, &topic, &body)) {
            PyMem_Free(msg);
            Py_RETURN_NONE; /* not every message is [topic, body]: the Python path */
        }
        m->topic = PyBytes_AS_STRING(topic);
        m->lt = PyBytes_GET_SIZE(topic);
        m->body = PyBytes_AS_STRING(body);
        m->lb = PyBytes_GET_SIZE(body);
        Py_ssize_t payload = 18 + m->lt + m->lb;
        if (payload > max_record)
            break;
        total += RECORD_HEADER + payload;
    }
    PyObject *blob = PyBytes_FromStringAndSize(NULL, total);
    PyObject *ends = PyList_New(done);
    if (blob == NULL || ends == NULL) {
        Py_XDECREF(blob);
        Py_XDECREF(ends);
        PyMem_Free(msg);
        return NULL;
    }
    unsigned char *base = (unsigned char *)PyBytes_AS_STRING(blob);
    /* the copies and CRCs without the GIL (the caller holds `records`, hence the bytes,
       and nothing else sees `blob` yet): a recorder thread runs beside the simulation */
    Py_BEGIN_ALLOW_THREADS
    unsigned char *o = base;
    for (Py_ssize_t i = 0; i < done; i++) {
        const message *g = &msg[i];
        Py_ssize_t payload = 18 + g->lt + g->lb;
        unsigned char *mid = o + 8, *p = o + RECORD_HEADER, *q = p;
        memcpy(o, SYNC, 8);
        /* payload: t_sim <d, 2 frames <H, topic length <I, topic, body length <I, body */
        q = put_le(q, double_bits(g->t), 8);
        q = put_le(q, 2, 2);
        q = put_le(q, (uint64_t)g->lt, 4);
        memcpy(q, g->topic, g->lt);
        q += g->lt;
        q = put_le(q, (uint64_t)g->lb, 4);
        memcpy(q, g->body, g->lb);
        uint32_t crc = crc32_update(0, p, (size_t)payload);
        /* mid <IHHQI: payload length, flags 0, reserved 0, sequence number, payload CRC */
        unsigned char *m = mid;
        m = put_le(m, (uint64_t)payload, 4);
        m = put_le(m, 0, 2);
        m = put_le(m, 0, 2);
        m = put_le(m, (uint64_t)(seq + (unsigned long long)i), 8);
        m = put_le(m, crc, 4);
        put_le(m, crc32_update(0, mid, 20), 4);
        o = p + payload;
    }
    Py_END_ALLOW_THREADS
    Py_ssize_t raw = 0, end = offset;
    for (Py_ssize_t i = 0; i < done; i++) {
        Py_ssize_t payload = 18 + msg[i].lt + msg[i].lb;
        raw += payload;
        end += RECORD_HEADER + payload;
        PyObject *e = PyLong_FromSsize_t(end);
        if (e == NULL) {
            Py_DECREF(blob);
            Py_DECREF(ends);
            PyMem_Free(msg);
            return NULL;
        }
        PyList_SET_ITEM(ends, i, e);
    }
    PyMem_Free(msg);
    return Py_BuildValue("(NNnn)", blob, ends, raw, done);
}

/* ------------------------------------------------------------------ module */
static PyMethodDef methods[] = {
    {"encode_slices", py_encode_slices, METH_VARARGS,
     "encode_slices(prefix, fixed, which, times, cols, ext_type, max_body) -> list[bytes]\n\n"
     "The bodies of sim.protocol.encode_slices: per message the prefix, its float64 time, "
     "its fixed part (fixed[which[j]], a tuple of bytes and an int64 index per message), "
     "then per column (key, head, itemsize, data, start, stop) its key, ext header, array "
     "head, element count and data slice.  OverflowError (the size) when a body exceeds "
     "max_body."},
    {"frame_records", py_frame_records, METH_VARARGS,
     "frame_records(records, seq, max_record, offset) -> (blob, ends, raw, done) or None\n\n"
     "Recording format-2 records of (t_sim, [topic, body]) messages numbered from seq, "
     "uncompressed, and where each ends (offset + its end in blob); stops before a record "
     "whose payload exceeds max_record (done < len(records)); None when a message is not "
     "two bytes frames."},
    {"crc32", py_crc32, METH_VARARGS,
     "crc32(data, crc=0, table=False): zlib.crc32, for the tests (table: the fallback's)."},
    {"uses_zlib", py_uses_zlib, METH_NOARGS, "True when the CRC-32 is zlib's own crc32."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_frames",
    "Compiled per-message byte work of the stream (see shipradar/_frames.c).", -1, methods,
};

PyMODINIT_FUNC PyInit__frames(void)
{
    crc_init();
    zlib_init();
    return PyModule_Create(&module);
}
