/* The MuJoCo backend's step loop in C.
 *
 * backends/mujoco/loop.py steps in Python: mj_step1, the layer's additions (motor offsets on
 * the friction rows, PyBullet's link damping, joint damping, one-step torques), then mj_step2 or
 * a split mj_step2 that makes the motor rows exact (the "polish") and clamps the speeds. That
 * Python is the reference; this file does the same arithmetic, in the same order, once per
 * step without leaving C, so a step costs what MuJoCo costs plus a few hundred nanoseconds.
 *
 * The module holds no MuJoCo symbol of its own: the caller passes the addresses of the MuJoCo
 * functions (taken from the libmujoco the Python bindings loaded) and of mjModel/mjData
 * (MjModel._address, MjData._address). The headers give the struct layouts; HEADER_VERSION lets
 * the caller refuse a kernel built against another MuJoCo.
 *
 * Arrays are borrowed from the caller (numpy, via the buffer protocol): the kernel keeps a
 * reference to each, and reads them at every step, so the caller's in-place command updates
 * are seen without a call here.
 *
 * Why one file of about 1,000 lines: it is one C extension module, compiled as one translation
 * unit so that the per-step helpers (motor offsets, limit rows, damping, the exact solve, the
 * polish, the clamp) inline into the step loop, with no header shared between .c files to keep
 * in step. Its sections follow the Python rooms it mirrors: loop.py (the step), solve.py (the
 * exact solve and the polish), damping.py (link damping and the clamp), reads.py (body_state),
 * commands.py (set_velocity), and the module's Python type at the end.
 */
#define PY_SSIZE_T_CLEAN
/* CPython's limited API as of 3.11 (the buffer protocol joined it in 3.11): one build, a
 * cp311-abi3 wheel, loads in 3.11 and every later CPython (setup.py: py_limited_api). Hence
 * the heap type made from a spec and the checked PyList_GetItem/PyFloat_AsDouble in place of
 * the macros: the same values; a command plus a step timed alike, docs/install.md. */
#ifndef Py_LIMITED_API
#define Py_LIMITED_API 0x030B0000
#endif
#include <Python.h>
#include <math.h>
#include <setjmp.h>
#include <stdio.h>
#include <string.h>

/* Phase timers for bench/kernel_phases.py, compiled in only with -DSIMBRIDGE_KERNEL_TIMERS. */
#ifdef SIMBRIDGE_KERNEL_TIMERS
#include <time.h>
#define N_TIMERS 7
static double timers[N_TIMERS];
static double now_ns(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec * 1e9 + t.tv_nsec;
}
#define TIC(i) (timers[i] -= now_ns())
#define TOC(i) (timers[i] += now_ns())
#else
#define TIC(i) ((void)0)
#define TOC(i) ((void)0)
#endif

#include <mujoco/mujoco.h>

typedef void (*mjfn)(const mjModel*, mjData*);
typedef void (*solvefn)(const mjModel*, mjData*, mjtNum*, const mjtNum*, int);
typedef void (*mat2quatfn)(mjtNum*, const mjtNum*);
typedef void (*objvelfn)(const mjModel*, const mjData*, int, int, mjtNum*, int);
typedef mjfLogHandler (*settlsfn)(mjfLogHandler);
typedef mjfLogHandler (*getglobalfn)(void);

/* the functions taken by address, in the order of kernel._FUNCTIONS (kernel.py) */
enum { F_STEP1, F_STEP2, F_ACT, F_ACC, F_CON, F_CHECKACC, F_EULER, F_KIN, F_COMPOS, F_COMVEL,
       N_FN };
/* + mj_solveM, mju_mat2Quat, mj_objectVelocity, _mjPRIVATE_setTlsLogHandler,
 *   _mjPRIVATE_getGlobalLogHandler */
#define N_ADDRESSES (N_FN + 5)

/* MuJoCo errors (mju_error: an arena or stack overflow, say). MuJoCo's default handler prints and
 * calls exit(); its Python bindings install a thread-local handler that jumps back to the caller.
 * The kernel does the same around its own calls: the handler keeps the message and longjmps to
 * the guarded call, which returns an error status; warnings go on to the handler that was active
 * before. Thread-local, so kernels stepping in several threads keep their errors apart. */
static settlsfn set_tls_handler;
static getglobalfn get_global_handler;
static _Thread_local jmp_buf error_jump;
static _Thread_local char error_text[2048];
static _Thread_local mjfLogHandler forward_handler;

static void error_handler(const mjLogMessage* msg) {
  if (msg->level != mjLOG_ERROR) {
    if (forward_handler) forward_handler(msg);
    return;
  }
  snprintf(error_text, sizeof(error_text), "%s%s%s", msg->func ? msg->func : "",
           msg->func ? ": " : "", msg->subject);
  longjmp(error_jump, 1);
}

typedef struct {
  Py_buffer buf;
  int held;
} Arr;

/* A command bound to the kernel (Sim.velocity_command, Sim.position_command): its own target
 * and force arrays, read at every step() call; a change is written with the command writes
 * below when the rows are armed, and sent through the Python path (resend) otherwise. */
typedef struct Bound {
  int used;
  int position;  /* 0 velocity, 1 position */
  int armed;     /* index (and limits) are valid for the motor rows bound now */
  int stale;     /* the motor rows were rebound since: send through Python at the next step */
  Py_ssize_t n;
  Arr index;     /* intp, 3 x n (slots, rows, dofs) or 4 x n (+ position rows) */
  Arr limits;    /* position: float64, 2 x n (lower, upper; -inf, inf: none) */
  Arr targets, force; /* the command's arrays (float64, n) */
  double* last;  /* 2 x n: the targets and forces last sent */
  PyObject* resend;   /* the Python path: checks, sends, and arms the command again */
} Bound;

typedef struct {
  PyObject_HEAD
  PyObject* owners;  /* (MjModel, MjData): kept alive while the kernel lives */
  const mjModel* m;
  mjData* d;
  mjfn fn[N_FN];
  solvefn solveM;
  mat2quatfn mat2quat;
  objvelfn objvel;
  double dt, clamp_limit, r_scale, limit_k, limit_deep, limit_k_in;
  int has_clamp;
  /* world arrays (bound once per compile) */
  Arr lin_gain, ang_gain;   /* (n,), (n,3) */
  int damp_first, damp_n;
  double* cfrc;             /* nbody x 6: link damping as spatial forces */
  Arr jd_dof, jd_coef;      /* joint damping: dof (intp), -damping */
  Arr tq_dof, tq;           /* one-step torques: motor dof (intp), torque */
  /* motor arrays (bound after every refresh) */
  int k;
  Arr offset, pos_rows, pos_qadr, pos_gain, kd_rows, kd_dof, kd_factor, dof_rows, slack;
  /* the motor table's commands (bound once per compile, for the command writes) */
  Arr cmd_target, cmd_force, cmd_position;
  Arr pos_target; /* the position rows' targets (MotorTable.position_target), optional */
  /* spherical position motors (bind_balls, after every bind_motors): rows, index into the
   * balls' errors, gains; per ball its quaternion's qpos address and target (x, y, z, w) */
  Arr ball_rows, ball_err_index, ball_gain, ball_qadr, ball_target;
  double* ball_err; /* 3 per ball */
  /* bound commands (Sim.velocity_command, Sim.position_command): read at every step() */
  struct Bound* bound;
  int n_bound;
  double *Y, *U, *A, *b;    /* k x nv, k x nv, k x k, k */
  int *free_rows, *piv;
  double *AM, *x;           /* exact_motors: k x k block of M^-1, k forces */
  int* side;                /* exact_motors: 0 free, +1 / -1 at the upper / lower bound */
  int cap;                  /* rows the scratch holds: k motor rows + 2 per limited joint */
  int* rdof;                /* exact_motors: each row's dof */
  double *rsign, *lo, *hi;  /* exact_motors: each row's Jacobian entry (+-1) and bounds */
  int busy; /* step() runs without the GIL: no other call may touch the kernel meanwhile */
  long done; /* steps completed by the last step() call (fewer than asked after an error) */
  int interrupted; /* the last step() raised a Python callback's exception mid-step */
  unsigned long started; /* step() calls begun: a read that saw it change was torn */
} Kernel;

/* step() releases the GIL while it runs, so another thread may call in meanwhile: refuse, with
 * the exception class set by set_busy_error (simbridge's SimBusyError; RuntimeError before). */
static PyObject* busy_error = NULL;

static int refuse_if_busy(const Kernel* self) {
  if (!self->busy) return 0;
  PyErr_SetString(busy_error ? busy_error : PyExc_RuntimeError,
                  "this Sim is stepping in another thread (or in a MuJoCo callback of its own "
                  "step); a Sim takes one call at a time (give each thread its own Sim)");
  return -1;
}

static PyObject* set_busy_error(PyObject* mod, PyObject* cls) {
  (void)mod;
  if (!PyExceptionClass_Check(cls)) {
    PyErr_SetString(PyExc_TypeError, "set_busy_error: an exception class");
    return NULL;
  }
  Py_INCREF(cls);
  PyObject* old = busy_error;
  busy_error = cls;
  Py_XDECREF(old);
  Py_RETURN_NONE;
}

static PyMethodDef module_methods[] = {
    {"set_busy_error", set_busy_error, METH_O, "the exception raised by a call on a busy kernel"},
    {NULL, NULL, 0, NULL},
};

static void arr_release(Arr* a) {
  if (a->held) {
    PyBuffer_Release(&a->buf);
    a->held = 0;
  }
}

/* Borrow a C-contiguous 1-D or 2-D buffer of float64 ('d') or intp ('n'/'l'/'q'). */
static int arr_take(Arr* a, PyObject* obj, char kind, Py_ssize_t n, const char* what) {
  arr_release(a);
  if (PyObject_GetBuffer(obj, &a->buf, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) return -1;
  a->held = 1;
  const char* f = a->buf.format ? a->buf.format : "B";
  if (*f == '<' || *f == '=' || *f == '@') f++;
  int ok;
  if (kind == 'd') {
    ok = strcmp(f, "d") == 0 && a->buf.itemsize == (Py_ssize_t)sizeof(double);
  } else {
    ok = (strcmp(f, "l") == 0 || strcmp(f, "q") == 0 || strcmp(f, "n") == 0) &&
         a->buf.itemsize == (Py_ssize_t)sizeof(Py_ssize_t);
  }
  if (!ok) {
    PyErr_Format(PyExc_TypeError, "%s: expected a contiguous %s array, got format '%s'", what,
                 kind == 'd' ? "float64" : "intp", a->buf.format ? a->buf.format : "?");
    arr_release(a);
    return -1;
  }
  if (n >= 0 && a->buf.len / a->buf.itemsize != n) {
    PyErr_Format(PyExc_ValueError, "%s: expected %zd elements, got %zd", what, n,
                 a->buf.len / a->buf.itemsize);
    arr_release(a);
    return -1;
  }
  return 0;
}

static Py_ssize_t arr_len(const Arr* a) { return a->held ? a->buf.len / a->buf.itemsize : 0; }
#define DP(a) ((double*)(a).buf.buf)
#define IP(a) ((const Py_ssize_t*)(a).buf.buf)

static void free_motor_scratch(Kernel* self) {
  PyMem_Free(self->Y);
  PyMem_Free(self->U);
  PyMem_Free(self->A);
  PyMem_Free(self->b);
  PyMem_Free(self->free_rows);
  PyMem_Free(self->piv);
  PyMem_Free(self->AM);
  PyMem_Free(self->x);
  PyMem_Free(self->side);
  PyMem_Free(self->rdof);
  PyMem_Free(self->rsign);
  PyMem_Free(self->lo);
  PyMem_Free(self->hi);
  self->Y = self->U = self->A = self->b = self->AM = self->x = NULL;
  self->rsign = self->lo = self->hi = NULL;
  self->free_rows = self->piv = self->side = self->rdof = NULL;
  self->cap = 0;
}

static void bound_clear(Bound* b) {
  arr_release(&b->index);
  arr_release(&b->limits);
  arr_release(&b->targets);
  arr_release(&b->force);
  PyMem_Free(b->last);
  b->last = NULL;
  Py_CLEAR(b->resend);
  b->used = b->armed = b->stale = 0;
  b->n = 0;
}

static void release_all(Kernel* self) {
  Arr* all[] = {&self->lin_gain, &self->ang_gain, &self->jd_dof,   &self->jd_coef,
                &self->tq_dof,   &self->tq,       &self->offset,   &self->pos_rows,
                &self->pos_qadr, &self->pos_gain, &self->kd_rows,  &self->kd_dof,
                &self->kd_factor, &self->dof_rows, &self->slack, &self->cmd_target,
                &self->cmd_force, &self->cmd_position, &self->pos_target,
                &self->ball_rows, &self->ball_err_index, &self->ball_gain, &self->ball_qadr,
                &self->ball_target};
  for (size_t i = 0; i < sizeof(all) / sizeof(all[0]); i++) arr_release(all[i]);
  for (int i = 0; i < self->n_bound; i++) bound_clear(&self->bound[i]);
  PyMem_Free(self->bound);
  self->bound = NULL;
  self->n_bound = 0;
  free_motor_scratch(self);
  self->k = 0;
  PyMem_Free(self->ball_err);
  self->ball_err = NULL;
  PyMem_Free(self->cfrc);
  self->cfrc = NULL;
  self->damp_n = 0;
}

static void Kernel_dealloc(Kernel* self) {
  release_all(self);
  Py_XDECREF(self->owners);
  PyTypeObject* type = Py_TYPE((PyObject*)self);
  ((freefunc)PyType_GetSlot(type, Py_tp_free))(self);
  Py_DECREF(type);
}

/* Kernel(model, data, model_address, data_address, functions, dt)
 * functions: addresses of mj_step1, mj_step2, mj_fwdActuation, mj_fwdAcceleration,
 * mj_fwdConstraint, mj_checkAcc, mj_Euler, mj_kinematics, mj_comPos, mj_comVel, mj_solveM,
 * mju_mat2Quat, mj_objectVelocity, _mjPRIVATE_setTlsLogHandler, _mjPRIVATE_getGlobalLogHandler
 * (in that order). */
static int Kernel_init(Kernel* self, PyObject* args, PyObject* kw) {
  PyObject *model, *data, *fns;
  unsigned long long maddr, daddr;
  double dt;
  if (!PyArg_ParseTuple(args, "OOKKOd", &model, &data, &maddr, &daddr, &fns, &dt)) return -1;
  if (!PyTuple_Check(fns) || PyTuple_Size(fns) != N_ADDRESSES) {
    PyErr_Format(PyExc_ValueError, "functions: a tuple of %d addresses", N_ADDRESSES);
    return -1;
  }
  if (!maddr || !daddr || !(dt > 0)) {
    PyErr_SetString(PyExc_ValueError, "null model/data address or dt <= 0");
    return -1;
  }
  void* f[N_ADDRESSES];
  for (int i = 0; i < N_ADDRESSES; i++) {
    f[i] = PyLong_AsVoidPtr(PyTuple_GetItem(fns, i));
    if (!f[i]) {
      if (!PyErr_Occurred()) PyErr_Format(PyExc_ValueError, "function %d: null address", i);
      return -1;
    }
  }
  release_all(self);
  Py_XDECREF(self->owners);
  self->owners = PyTuple_Pack(2, model, data);
  if (!self->owners) return -1;
  self->m = (const mjModel*)(uintptr_t)maddr;
  self->d = (mjData*)(uintptr_t)daddr;
  for (int i = 0; i < N_FN; i++) self->fn[i] = (mjfn)f[i];
  self->solveM = (solvefn)f[N_FN];
  self->mat2quat = (mat2quatfn)f[N_FN + 1];
  self->objvel = (objvelfn)f[N_FN + 2];
  set_tls_handler = (settlsfn)f[N_FN + 3];
  get_global_handler = (getglobalfn)f[N_FN + 4];
  self->dt = dt;
  self->has_clamp = 0;
  self->clamp_limit = INFINITY;
  self->r_scale = 1.0;
  self->limit_k = 0.0;
  self->limit_deep = INFINITY;
  self->limit_k_in = 0.0;
  self->damp_n = 0;
  return 0;
}

/* bind_world(first, lin_gain, ang_gain, jd_dof, jd_coef, tq_dof, tq, clamp_limit_or_None,
 *            r_scale, limit_k, limit_deep[, limit_k_in]): link damping of the bodies first ..
 * first + len(lin_gain) - 1, joint damping, one-step torques, the speed clamp, the motor and
 * limit rows' hardening, the limit rows' position gain and the depth past which it is dropped,
 * and their gain inside the range (limit_rule "hard"; 0: none) */
static PyObject* Kernel_bind_world(Kernel* self, PyObject* args) {
  if (refuse_if_busy(self) < 0) return NULL;
  int first;
  PyObject *lg, *ag, *jdd, *jdc, *tqd, *tq, *limit;
  double r_scale, limit_k, limit_deep, limit_k_in = 0.0;
  if (!PyArg_ParseTuple(args, "iOOOOOOOddd|d", &first, &lg, &ag, &jdd, &jdc, &tqd, &tq, &limit,
                        &r_scale, &limit_k, &limit_deep, &limit_k_in))
    return NULL;
  const mjModel* m = self->m;
  if (arr_take(&self->lin_gain, lg, 'd', -1, "lin_gain") < 0) return NULL;
  Py_ssize_t n = arr_len(&self->lin_gain);
  if (arr_take(&self->ang_gain, ag, 'd', 3 * n, "ang_gain") < 0) return NULL;
  if (n && (first < 1 || first + n > m->nbody)) {
    PyErr_SetString(PyExc_ValueError, "damping bodies out of the model's range");
    return NULL;
  }
  if (arr_take(&self->jd_dof, jdd, 'n', -1, "joint damping dofs") < 0) return NULL;
  if (arr_take(&self->jd_coef, jdc, 'd', arr_len(&self->jd_dof), "joint damping") < 0)
    return NULL;
  if (arr_take(&self->tq_dof, tqd, 'n', -1, "torque dofs") < 0) return NULL;
  if (arr_take(&self->tq, tq, 'd', arr_len(&self->tq_dof), "torques") < 0) return NULL;
  for (Py_ssize_t i = 0; i < arr_len(&self->jd_dof); i++)
    if (IP(self->jd_dof)[i] < 0 || IP(self->jd_dof)[i] >= m->nv) goto bad_dof;
  for (Py_ssize_t i = 0; i < arr_len(&self->tq_dof); i++)
    if (IP(self->tq_dof)[i] < 0 || IP(self->tq_dof)[i] >= m->nv) goto bad_dof;
  PyMem_Free(self->cfrc);
  self->cfrc = NULL;
  self->damp_n = 0;
  if (n) {
    self->cfrc = PyMem_Calloc(6 * (size_t)m->nbody, sizeof(double));
    if (!self->cfrc) return PyErr_NoMemory();
  }
  self->damp_first = first;
  self->damp_n = (int)n;
  self->has_clamp = limit != Py_None;
  self->clamp_limit = self->has_clamp ? PyFloat_AsDouble(limit) : INFINITY;
  if (PyErr_Occurred()) return NULL;
  self->r_scale = r_scale;
  self->limit_k = limit_k;
  self->limit_deep = limit_deep;
  self->limit_k_in = limit_k_in;
  Py_RETURN_NONE;
bad_dof:
  PyErr_SetString(PyExc_ValueError, "a dof index out of the model's range");
  return NULL;
}

static void release_balls(Kernel* self) {
  arr_release(&self->ball_rows);
  arr_release(&self->ball_err_index);
  arr_release(&self->ball_gain);
  arr_release(&self->ball_qadr);
  arr_release(&self->ball_target);
  PyMem_Free(self->ball_err);
  self->ball_err = NULL;
}

/* bind_balls(rows, error_index, gain, qadr, target): the spherical position motors after a
 * bind_motors (MotorTable.ball_rows, ball_row_error, ball_gain, ball_pos_qadr,
 * ball_pos_target): row r's offset less gain * error[error_index], the errors of each ball's
 * quaternion at qpos[qadr..qadr+3] against its target (4 per ball). */
static PyObject* Kernel_bind_balls(Kernel* self, PyObject* args) {
  if (refuse_if_busy(self) < 0) return NULL;
  PyObject *o[5];
  if (!PyArg_ParseTuple(args, "OOOOO", &o[0], &o[1], &o[2], &o[3], &o[4])) return NULL;
  release_balls(self);
  const mjModel* m = self->m;
  if (arr_take(&self->ball_rows, o[0], 'n', -1, "ball_rows") < 0) return NULL;
  Py_ssize_t n = arr_len(&self->ball_rows);
  if (arr_take(&self->ball_err_index, o[1], 'n', n, "ball_row_error") < 0 ||
      arr_take(&self->ball_gain, o[2], 'd', n, "ball_gain") < 0 ||
      arr_take(&self->ball_qadr, o[3], 'n', -1, "ball_pos_qadr") < 0)
    goto fail;
  Py_ssize_t nb = arr_len(&self->ball_qadr);
  if (arr_take(&self->ball_target, o[4], 'd', 4 * nb, "ball_pos_target") < 0) goto fail;
  for (Py_ssize_t i = 0; i < n; i++)
    if (IP(self->ball_rows)[i] < 0 || IP(self->ball_rows)[i] >= self->k ||
        IP(self->ball_err_index)[i] < 0 || IP(self->ball_err_index)[i] >= 3 * nb)
      goto bad;
  for (Py_ssize_t i = 0; i < nb; i++)
    if (IP(self->ball_qadr)[i] < 0 || IP(self->ball_qadr)[i] + 4 > m->nq) goto bad;
  if (nb) {
    self->ball_err = PyMem_Calloc((size_t)(3 * nb), sizeof(double));
    if (!self->ball_err) {
      release_balls(self);
      return PyErr_NoMemory();
    }
  }
  Py_RETURN_NONE;
bad:
  PyErr_SetString(PyExc_ValueError, "a spherical motor's row, error or qpos index out of range");
fail:
  release_balls(self);
  return NULL;
}

/* motor_rows.spherical_error: Bullet's matrixToEulerXYZ of conj(q) * t, q = (w, x, y, z) as MuJoCo
 * keeps it, t = (x, y, z, w); the same arithmetic in the same order as the Python. */
static void spherical_error(const double* q, const double* t, double* e) {
  double cx = -q[1], cy = -q[2], cz = -q[3], cw = q[0];
  double tx = t[0], ty = t[1], tz = t[2], tw = t[3];
  double rx = cw * tx + cx * tw + cy * tz - cz * ty;
  double ry = cw * ty + cy * tw + cz * tx - cx * tz;
  double rz = cw * tz + cz * tw + cx * ty - cy * tx;
  double rw = cw * tw - cx * tx - cy * ty - cz * tz;
  double s = 2.0 / (rx * rx + ry * ry + rz * rz + rw * rw);
  double xs = rx * s, ys = ry * s, zs = rz * s;
  double wx = rw * xs, wy = rw * ys, wz = rw * zs;
  double xx = rx * xs, xy = rx * ys, xz = rx * zs;
  double yy = ry * ys, yz = ry * zs, zz = rz * zs;
  double m20 = xz - wy;
  if (m20 < 1.0) {
    if (m20 > -1.0) {
      e[0] = atan2(-(yz + wx), 1.0 - (xx + yy));
      e[1] = asin(m20);
      e[2] = atan2(-(xy + wz), 1.0 - (yy + zz));
      return;
    }
    e[0] = -atan2(xy - wz, 1.0 - (xx + zz));
    e[1] = -0.5 * 3.141592653589793;
    e[2] = 0.0;
    return;
  }
  e[0] = atan2(xy - wz, 1.0 - (xx + zz));
  e[1] = 0.5 * 3.141592653589793;
  e[2] = 0.0;
}

/* bind_motors(offset, pos_rows, pos_qadr, pos_gain, kd_rows, kd_dof, kd_factor, dof_rows,
 *             slack[, pos_target[, keep_bound]]): the motor rows after a refresh (k =
 * len(dof_rows)); the position rows' targets are needed by set_position. Unless keep_bound
 * (a command on other motors, rows in the same places), every bound command is made stale:
 * its rows may have moved and the table may have been rewritten, so the next step hands it
 * to Python (which checks it against the table, and sends it or arms it again). */
static PyObject* Kernel_bind_motors(Kernel* self, PyObject* args) {
  if (refuse_if_busy(self) < 0) return NULL;
  PyObject *o[10] = {NULL};
  int keep = 0;
  if (!PyArg_ParseTuple(args, "OOOOOOOOO|Op", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6],
                        &o[7], &o[8], &o[9], &keep))
    return NULL;
  const mjModel* m = self->m;
  free_motor_scratch(self);
  self->k = 0;
  arr_release(&self->pos_target);
  release_balls(self);
  for (int i = 0; i < self->n_bound && !keep; i++) {
    self->bound[i].armed = 0;
    self->bound[i].stale = 1;
  }
  if (arr_take(&self->dof_rows, o[7], 'n', -1, "dof_rows") < 0) return NULL;
  Py_ssize_t k = arr_len(&self->dof_rows);
  if (arr_take(&self->offset, o[0], 'd', k, "offset_rows") < 0 ||
      arr_take(&self->pos_rows, o[1], 'n', -1, "position_rows") < 0 ||
      arr_take(&self->pos_qadr, o[2], 'n', arr_len(&self->pos_rows), "position_qadr") < 0 ||
      arr_take(&self->pos_gain, o[3], 'd', arr_len(&self->pos_rows), "position_gain") < 0 ||
      arr_take(&self->kd_rows, o[4], 'n', -1, "kd_rows") < 0 ||
      arr_take(&self->kd_dof, o[5], 'n', arr_len(&self->kd_rows), "kd_dof") < 0 ||
      arr_take(&self->kd_factor, o[6], 'd', arr_len(&self->kd_rows), "kd_factor") < 0 ||
      arr_take(&self->slack, o[8], 'd', k, "force_rows_slack") < 0 ||
      (o[9] && arr_take(&self->pos_target, o[9], 'd', arr_len(&self->pos_rows),
                        "position_target") < 0))
    return NULL;
  for (Py_ssize_t i = 0; i < k; i++)
    if (IP(self->dof_rows)[i] < 0 || IP(self->dof_rows)[i] >= m->nv) goto bad;
  for (Py_ssize_t i = 0; i < arr_len(&self->pos_rows); i++)
    if (IP(self->pos_rows)[i] < 0 || IP(self->pos_rows)[i] >= k ||
        IP(self->pos_qadr)[i] < 0 || IP(self->pos_qadr)[i] >= m->nq)
      goto bad;
  for (Py_ssize_t i = 0; i < arr_len(&self->kd_rows); i++)
    if (IP(self->kd_rows)[i] < 0 || IP(self->kd_rows)[i] >= k || IP(self->kd_dof)[i] < 0 ||
        IP(self->kd_dof)[i] >= m->nv)
      goto bad;
  if (k) {
    int nv = m->nv;
    size_t c = (size_t)k;
    for (int j = 0; j < m->njnt; j++) /* room for the limit rows of the exact solve */
      if (m->jnt_limited[j] && (m->jnt_type[j] == mjJNT_HINGE || m->jnt_type[j] == mjJNT_SLIDE))
        c += 2;
    self->Y = PyMem_Calloc(c * nv, sizeof(double));
    self->U = PyMem_Calloc(c * nv, sizeof(double));
    self->A = PyMem_Calloc(c * c, sizeof(double));
    self->b = PyMem_Calloc(c, sizeof(double));
    self->free_rows = PyMem_Calloc(c, sizeof(int));
    self->piv = PyMem_Calloc(c, sizeof(int));
    self->AM = PyMem_Calloc(c * c, sizeof(double));
    self->x = PyMem_Calloc(c, sizeof(double));
    self->side = PyMem_Calloc(c, sizeof(int));
    self->rdof = PyMem_Calloc(c, sizeof(int));
    self->rsign = PyMem_Calloc(c, sizeof(double));
    self->lo = PyMem_Calloc(c, sizeof(double));
    self->hi = PyMem_Calloc(c, sizeof(double));
    self->cap = (int)c;
    if (!self->Y || !self->U || !self->A || !self->b || !self->free_rows || !self->piv ||
        !self->AM || !self->x || !self->side || !self->rdof || !self->rsign || !self->lo ||
        !self->hi) {
      free_motor_scratch(self);
      return PyErr_NoMemory();
    }
  }
  self->k = (int)k;
  Py_RETURN_NONE;
bad:
  PyErr_SetString(PyExc_ValueError, "a motor row, dof or qpos index out of range");
  return NULL;
}

/* PyBullet's link damping, added to qfrc_passive as generalised forces
 * (damping.LinkDamping.apply, the same arithmetic). Each body's force
 * and torque become a spatial force about its tree's centre of mass (the point cvel and cdof
 * refer to), summed up the tree, and projected on every dof through cdof. */
static void link_damping(Kernel* self) {
  const mjModel* m = self->m;
  mjData* d = self->d;
  const double* lin = DP(self->lin_gain);
  const double* ang = DP(self->ang_gain);
  double* cf = self->cfrc;
  memset(cf, 0, sizeof(double) * 6 * (size_t)m->nbody);
  for (int i = 0; i < self->damp_n; i++) {
    int b = self->damp_first + i;
    const double* w = d->cvel + 6 * b;
    const double* c = d->subtree_com + 3 * m->body_rootid[b];
    const double* p = d->xipos + 3 * b;
    double r[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
    double v[3]; /* velocity of the centre of mass: cvel's linear part moved to xipos */
    v[0] = w[3] - (r[1] * w[2] - r[2] * w[1]);
    v[1] = w[4] - (r[2] * w[0] - r[0] * w[2]);
    v[2] = w[5] - (r[0] * w[1] - r[1] * w[0]);
    double sv = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    double sw = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double g = lin[i] * (sv + 1.0);
    double f[3] = {v[0] * g, v[1] * g, v[2] * g};
    const double* R = d->ximat + 9 * b; /* world = R local */
    double tl[3], t[3];
    for (int k = 0; k < 3; k++)
      tl[k] = (R[k] * w[0] + R[3 + k] * w[1] + R[6 + k] * w[2]) * ang[3 * i + k] * (sw + 1.0);
    for (int k = 0; k < 3; k++) t[k] = R[3 * k] * tl[0] + R[3 * k + 1] * tl[1] + R[3 * k + 2] * tl[2];
    double* s = cf + 6 * b;
    s[0] = t[0] + r[1] * f[2] - r[2] * f[1];
    s[1] = t[1] + r[2] * f[0] - r[0] * f[2];
    s[2] = t[2] + r[0] * f[1] - r[1] * f[0];
    s[3] = f[0];
    s[4] = f[1];
    s[5] = f[2];
  }
  for (int b = m->nbody - 1; b > 0; b--) {
    int parent = m->body_parentid[b];
    if (parent > 0)
      for (int k = 0; k < 6; k++) cf[6 * parent + k] += cf[6 * b + k];
  }
  for (int j = 0; j < m->nv; j++) {
    const double* s = cf + 6 * m->dof_bodyid[j];
    const double* cd = d->cdof + 6 * j;
    d->qfrc_passive[j] += cd[0] * s[0] + cd[1] * s[1] + cd[2] * s[2] + cd[3] * s[3] +
                          cd[4] * s[4] + cd[5] * s[5];
  }
}

/* Solve A x = b (n x n, row-major, overwritten) by LU with partial pivoting; x in b.
 * Returns 0, or -1 for a singular matrix. */
static int lu_solve(double* A, double* b, int* piv, int n) {
  for (int c = 0; c < n; c++) {
    int p = c;
    double best = fabs(A[c * n + c]);
    for (int r = c + 1; r < n; r++)
      if (fabs(A[r * n + c]) > best) best = fabs(A[r * n + c]), p = r;
    if (!(best > 0.0)) return -1;
    piv[c] = p;
    if (p != c) {
      for (int j = 0; j < n; j++) {
        double t = A[c * n + j];
        A[c * n + j] = A[p * n + j];
        A[p * n + j] = t;
      }
      double t = b[c];
      b[c] = b[p];
      b[p] = t;
    }
    for (int r = c + 1; r < n; r++) {
      double f = A[r * n + c] / A[c * n + c];
      if (f == 0.0) continue;
      for (int j = c + 1; j < n; j++) A[r * n + j] -= f * A[c * n + j];
      b[r] -= f * b[c];
    }
  }
  for (int r = n - 1; r >= 0; r--) {
    double s = b[r];
    for (int j = r + 1; j < n; j++) s -= A[r * n + j] * b[j];
    b[r] = s / A[r * n + r];
  }
  return 0;
}

/* Y[i] = the row of M^-1 for the dof of motor row rows[i] (rows NULL: row i), i < n; U holds
 * their unit rows during the solve and is left zero. */
static void minv_rows(Kernel* self, const int* rows, int n) {
  const int nv = self->m->nv;
  const Py_ssize_t* dofs = IP(self->dof_rows);
  for (int i = 0; i < n; i++) self->U[i * nv + dofs[rows ? rows[i] : i]] = 1.0;
  self->solveM(self->m, self->d, self->Y, self->U, n);
  for (int i = 0; i < n; i++) self->U[i * nv + dofs[rows ? rows[i] : i]] = 0.0;
}

/* Make the free motor rows exact (MujocoBackend._polish). */
static int polish(Kernel* self) {
  const mjModel* m = self->m;
  mjData* d = self->d;
  int k = self->k, nv = m->nv;
  const Py_ssize_t* dofs = IP(self->dof_rows);
  const double* slack = DP(self->slack);
  double* force = d->efc_force;
  double* qacc = d->qacc;
  const double* aref = d->efc_aref;
  int nf = 0;
  for (int r = 0; r < k; r++)
    if (fabs(force[r]) < slack[r]) self->free_rows[nf++] = r;
  if (!nf) return 0;
  minv_rows(self, self->free_rows, nf);
  double* A = self->A;
  double* b = self->b;
  for (int i = 0; i < nf; i++) {
    int r = self->free_rows[i];
    b[i] = aref[r] - qacc[dofs[r]];
    for (int j = 0; j < nf; j++) A[i * nf + j] = self->Y[i * nv + dofs[self->free_rows[j]]];
  }
  if (lu_solve(A, b, self->piv, nf) < 0) return -1;
  for (int c = 0; c < nv; c++) {
    double s = 0.0;
    for (int i = 0; i < nf; i++) s += b[i] * self->Y[i * nv + c];
    qacc[c] += s;
  }
  for (int i = 0; i < nf; i++) {
    int r = self->free_rows[i];
    qacc[dofs[r]] = aref[r];
    force[r] += b[i];
  }
  return 0;
}

/* The Jacobian entry of row r at dof (MuJoCo keeps efc_J dense below 60 dofs unless told). */
static double jac_entry(const mjModel* m, const mjData* d, int r, int dof) {
  int sparse = m->opt.jacobian == mjJAC_SPARSE || (m->opt.jacobian == mjJAC_AUTO && m->nv >= 60);
  if (!sparse) return d->efc_J[(size_t)r * m->nv + dof];
  int adr = d->efc_J_rowadr[r];
  for (int i = 0; i < d->efc_J_rownnz[r]; i++)
    if (d->efc_J_colind[adr + i] == dof) return d->efc_J[adr + i];
  return 0.0;
}

/* When the motor rows and joint-limit rows are the only constraint rows (no contact), solve
 * them exactly instead of calling mj_fwdConstraint and polishing (MujocoBackend._exact_motors,
 * the same steps in the same order): PyBullet's box-constrained problem,
 *     A x = b on the free rows, x at a bound on the others,
 * bounds +-max_force for a motor row and [0, inf) for a limit row (it only pushes), A the rows'
 * block of J M^-1 J^T (each row is +-1 at one dof), b = aref - J qacc_smooth, found by an active
 * set (the free row furthest past a bound goes to it; a row at a bound whose acceleration
 * overshoots its aref is freed). Writes efc_force, qfrc_constraint and qacc. Returns 0; 1 when
 * other rows are present (the caller runs MuJoCo's solver); -1 singular or no convergence (the
 * caller falls back to MuJoCo's solver). */
static int exact_motors(Kernel* self) {
  const mjModel* m = self->m;
  mjData* d = self->d;
  const int k = self->k, nv = m->nv, n = d->nefc;
  if (d->ne || d->nf != k || n > self->cap) return 1;
  for (int r = k; r < n; r++)
    if (d->efc_type[r] != mjCNSTR_LIMIT_JOINT) return 1;
  const Py_ssize_t* dofs = IP(self->dof_rows);
  const double* aref = d->efc_aref;
  int *rdof = self->rdof, *side = self->side, *fr = self->free_rows;
  double *sg = self->rsign, *lo = self->lo, *hi = self->hi;
  double *AM = self->AM, *x = self->x, *b = self->b, *A = self->A;
  for (int r = 0; r < n; r++) {
    if (r < k) {
      rdof[r] = (int)dofs[r];
      sg[r] = 1.0;
      hi[r] = d->efc_frictionloss[r];
      lo[r] = -hi[r];
    } else {
      rdof[r] = m->jnt_dofadr[d->efc_id[r]];
      sg[r] = jac_entry(m, d, r, rdof[r]);
      lo[r] = 0.0;
      hi[r] = INFINITY;
    }
    self->U[r * nv + rdof[r]] = 1.0;
  }
  self->solveM(m, d, self->Y, self->U, n);
  for (int r = 0; r < n; r++) {
    self->U[r * nv + rdof[r]] = 0.0;
    for (int c = 0; c < n; c++) AM[r * n + c] = sg[r] * sg[c] * self->Y[r * nv + rdof[c]];
    /* motor rows start free, limit rows at zero force: a joint resting at its limit under a
     * holding motor is then solved by the motor alone (both free would be singular) */
    side[r] = r < k ? 0 : -1;
  }
  /* a limit row the first round would free starts free, the motor row on its dof at the bound
   * pushing into the limit (one solve less a step for a joint held on its limit): with the
   * motor row free at the start, the dof accelerates at the motor's aref, so the limit row's
   * need is known before any solve; it must pass the loop's freeing tolerance taken with every
   * motor at its force bound (what round-off in its acceleration scales with, at most) */
  for (int r = k; r < n; r++) {
    int mr = -1;
    for (int c = 0; c < k && mr < 0; c++)
      if (rdof[c] == rdof[r]) mr = c;
    if (mr < 0) continue;
    double terms = fabs(aref[r]) + fabs(sg[r] * d->qacc_smooth[rdof[r]]);
    for (int c = 0; c < k; c++) terms += fabs(AM[r * n + c]) * hi[c];
    if (aref[r] - sg[r] * aref[mr] > 1e-9 * terms) {
      side[r] = 0;
      side[mr] = sg[r] > 0.0 ? -1 : 1;
    }
  }
  int done = 0;
  for (int it = 0; it < 4 * n + 4 && !done; it++) {
    int nf = 0;
    for (int r = 0; r < n; r++) {
      if (side[r]) {
        x[r] = side[r] > 0 ? hi[r] : lo[r];
      } else {
        fr[nf++] = r;
      }
    }
    for (int i = 0; i < nf; i++) { /* A_FF x_F = b_F - A_FC x_C */
      int r = fr[i];
      double rhs = aref[r] - sg[r] * d->qacc_smooth[rdof[r]];
      for (int c = 0; c < n; c++)
        if (side[c]) rhs -= AM[r * n + c] * x[c];
      b[i] = rhs;
      for (int j = 0; j < nf; j++) A[i * nf + j] = AM[r * n + fr[j]];
    }
    if (nf && lu_solve(A, b, self->piv, nf) < 0) return -1;
    for (int i = 0; i < nf; i++) x[fr[i]] = b[i];
    int worst = -1, to = 0;
    double over = 0.0;
    for (int i = 0; i < nf; i++) { /* the free row furthest past a bound */
      int r = fr[i];
      double scale = r < k ? hi[r] : fabs(aref[r] - sg[r] * d->qacc_smooth[rdof[r]]) /
                                         AM[r * n + r] + 1e-300;
      double up = (x[r] - hi[r]) / scale, down = (lo[r] - x[r]) / scale;
      if (up > 1e-12 && up > over) over = up, worst = r, to = 1;
      if (down > 1e-12 && down > over) over = down, worst = r, to = -1;
    }
    if (worst >= 0) {
      side[worst] = to;
      continue;
    }
    int freed = -1;
    double most = 0.0;
    int nover = 0; /* the limit rows that overshoot, in fr (the free list is used up) */
    for (int r = 0; r < n; r++) { /* a row at a bound whose acceleration overshoots its aref */
      if (!side[r]) continue;
      double acc = sg[r] * d->qacc_smooth[rdof[r]], scale = fabs(aref[r] - acc);
      double terms = fabs(aref[r]) + fabs(acc); /* what round-off in acc scales with */
      for (int c = 0; c < n; c++) {
        acc += AM[r * n + c] * x[c];
        terms += fabs(AM[r * n + c] * x[c]);
      }
      double v = side[r] * (acc - aref[r]);
      scale += fabs(AM[r * n + r]) * fabs(x[r]);
      /* a limit row at zero force is freed only past round-off: a joint resting at its limit
       * under a holding motor leaves it at zero (freeing it there is degenerate) */
      double tol = r < k ? 1e-12 * scale : 1e-9 * terms;
      if (v > tol && v > most) most = v, freed = r;
      if (v > tol && r >= k) fr[nover++] = r;
    }
    if (freed >= 0) {
      const int was = side[freed];
      side[freed] = 0;
      /* a limit row is freed with every other limit row that overshoots (one solve for the
       * joints that reach their limits together, not one each); a limit row needed on the dof
       * of a free motor row: both would ask for the same dof's acceleration (a singular
       * block), so the motor cannot reach its target past the limit and pushes into the limit
       * at its force bound (the bound opposite the limit's push: the only consistent one; the
       * sign of its free force is not it where the motor brakes a joint that gravity drives
       * into the limit, and that cycled) */
      for (int i = 0; freed >= k && i < nover; i++) {
        const int l = fr[i];
        side[l] = 0;
        for (int r = 0; r < k; r++)
          if (!side[r] && rdof[r] == rdof[l]) side[r] = sg[l] > 0.0 ? -1 : 1;
      }
      /* a motor row freed on the dof of a free limit row: pushing the way its limit pushes
       * and asking for less, it goes to the other bound (the limit holds the dof's
       * acceleration: the only consistent one; freed, it went back to this one and cycled);
       * pushing into its limit and asking to leave it, it takes the dof over and the limit row
       * goes back to zero force (freed again if still needed) */
      int held = -1;
      for (int r = k; freed < k && r < n; r++)
        if (!side[r] && rdof[r] == rdof[freed] && held < 0) held = r;
      if (held >= 0 && was == (sg[held] > 0.0 ? 1 : -1)) {
        side[freed] = -was;
      } else {
        for (int r = k; freed < k && r < n; r++)
          if (!side[r] && rdof[r] == rdof[freed]) side[r] = -1;
      }
      continue;
    }
    done = 1;
  }
  if (!done) return -1;
  double* qacc = d->qacc;
  for (int c = 0; c < nv; c++) {
    double s = d->qacc_smooth[c];
    for (int r = 0; r < n; r++) s += x[r] * sg[r] * self->Y[r * nv + c];
    qacc[c] = s;
    d->qfrc_constraint[c] = 0.0;
  }
  for (int r = 0; r < n; r++) {
    if (r < k && !side[r]) qacc[rdof[r]] = aref[r]; /* free motor rows exactly, no round-off */
    d->efc_force[r] = x[r];
    d->qfrc_constraint[rdof[r]] += sg[r] * x[r];
  }
  return 0;
}

static int warning_count(const mjData* d) {
  return d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number +
         d->warning[mjWARN_BADQACC].number;
}

/* n steps of the loop; 0 ok, 1 a divergence warning was raised (the loop stops after that
 * step), 2 the friction rows are not the motor rows, 3 a singular motor solve; self->done: the
 * steps completed */
static int run_steps(Kernel* self, long n, int pending) {
  const mjModel* m = self->m;
  mjData* d = self->d;
  const int k = self->k;
  const int nt = (int)arr_len(&self->tq_dof), njd = (int)arr_len(&self->jd_dof);
  const int before = warning_count(d);
  int status = 0;
  long s;
  for (s = 0; s < n && !status; s++) {
    self->done = s; /* kept through a jump out of a failed step */
    TIC(0);
    self->fn[F_STEP1](m, d);
    TOC(0);
    TIC(1);
    if (k) {
      if (d->nf < k) {
        status = 2;
        break;
      }
      const double* off = DP(self->offset);
      double* aref = d->efc_aref;
      Py_ssize_t np_ = arr_len(&self->pos_rows);
      Py_ssize_t nbr = arr_len(&self->ball_rows);
      if (np_ || nbr) {
        /* aref += offset - gain q on position rows, - gain e on spherical ones (aref_offset) */
        for (int r = 0; r < k; r++) self->b[r] = off[r];
        for (Py_ssize_t i = 0; i < np_; i++)
          self->b[IP(self->pos_rows)[i]] -= DP(self->pos_gain)[i] * d->qpos[IP(self->pos_qadr)[i]];
        if (nbr) {
          Py_ssize_t nb = arr_len(&self->ball_qadr);
          for (Py_ssize_t i = 0; i < nb; i++)
            spherical_error(d->qpos + IP(self->ball_qadr)[i], DP(self->ball_target) + 4 * i,
                            self->ball_err + 3 * i);
          for (Py_ssize_t i = 0; i < nbr; i++)
            self->b[IP(self->ball_rows)[i]] -=
                DP(self->ball_gain)[i] * self->ball_err[IP(self->ball_err_index)[i]];
        }
        for (int r = 0; r < k; r++) aref[r] += self->b[r];
      } else {
        for (int r = 0; r < k; r++) aref[r] += off[r];
      }
      const double inv = 1.0 / self->r_scale;
      for (int r = 0; r < k; r++) {
        d->efc_R[r] *= self->r_scale;
        d->efc_D[r] *= inv;
      }
    }
    if (d->nl) { /* PyBullet's limit rows (motor_rows.py), after the friction rows */
      const double inv = 1.0 / self->r_scale;
      for (int r = d->nf; r < d->nf + d->nl; r++) {
        d->efc_R[r] *= self->r_scale;
        d->efc_D[r] *= inv;
        /* MuJoCo's position term is K (pos - margin); PyBullet's is K pos for a penetration
         * (pos <= 0) under limit_deep, none deeper (stop only) or inside the margin */
        double pos = d->efc_pos[r], margin = d->efc_margin[r];
        d->efc_aref[r] += self->limit_k * (pos - margin);
        if (pos <= 0.0 && pos > -self->limit_deep) d->efc_aref[r] -= self->limit_k * pos;
        /* limit_rule "hard": inside the range, stop on the limit (motor_rows.py) */
        else if (pos > 0.0 && self->limit_k_in != 0.0) d->efc_aref[r] -= self->limit_k_in * pos;
      }
    }
    TOC(1);
    TIC(2);
    if (self->damp_n) link_damping(self);
    for (int i = 0; i < njd; i++)
      d->qfrc_applied[IP(self->jd_dof)[i]] = DP(self->jd_coef)[i] * d->qvel[IP(self->jd_dof)[i]];
    if (pending)
      for (int i = 0; i < nt; i++) d->qfrc_applied[IP(self->tq_dof)[i]] += DP(self->tq)[i];
    TOC(2);
    if (k || self->has_clamp) {
      TIC(3);
      self->fn[F_ACT](m, d);
      self->fn[F_ACC](m, d);
      TOC(3);
      for (Py_ssize_t i = 0; i < arr_len(&self->kd_rows); i++)
        d->efc_aref[IP(self->kd_rows)[i]] += DP(self->kd_factor)[i] * d->qacc_smooth[IP(self->kd_dof)[i]];
      TIC(4);
      int exact = k && exact_motors(self) == 0;
      if (!exact) self->fn[F_CON](m, d);
      TOC(4);
      TIC(5);
      if (k && !exact && polish(self) < 0) status = 3;
      TOC(5);
      if (self->has_clamp) { /* PyBullet clamps every dof's speed at every step */
        double L = self->clamp_limit, dt = self->dt;
        for (int i = 0; i < m->nv; i++) {
          double lo = (-L - d->qvel[i]) / dt, hi = (L - d->qvel[i]) / dt;
          double a = d->qacc[i];
          d->qacc[i] = a < lo ? lo : (a > hi ? hi : a);
        }
      }
      TIC(6);
      self->fn[F_CHECKACC](m, d);
      self->fn[F_EULER](m, d);
      TOC(6);
    } else {
      self->fn[F_STEP2](m, d);
    }
    if (pending) {
      pending = 0;
      double* tq = DP(self->tq);
      for (int i = 0; i < nt; i++) {
        d->qfrc_applied[IP(self->tq_dof)[i]] = 0.0;
        tq[i] = 0.0;
      }
    }
    if (!status && warning_count(d) != before) {
      /* MuJoCo found a bad position, speed or acceleration in this step and put the state
       * back to the model's reference pose: the world is not the simulation any more, so
       * the loop stops after this step (the error then names its time) */
      status = 1;
      s++;
      break;
    }
  }
  self->done = s;
  return status;
}

/* run_steps (job 0) or the lazy kinematics (job 1) under the error handler: 4 when MuJoCo
 * raised an error (its text in error_text, for last_error()). */
static int guarded(Kernel* self, int job, long n, int pending) {
  /* a kernel call may nest in another on this thread (a MuJoCo callback in Python stepping
   * another Sim): keep the outer call's jump target and forwarding, and never forward to
   * ourselves */
  jmp_buf outer;
  memcpy(outer, error_jump, sizeof(jmp_buf));
  mjfLogHandler prev = set_tls_handler(error_handler);
  mjfLogHandler saved = forward_handler;
  if (prev != error_handler) forward_handler = prev ? prev : get_global_handler();
  int status;
  if (setjmp(error_jump) == 0) {
    if (job == 0) {
      status = run_steps(self, n, pending);
    } else {
      self->fn[F_KIN](self->m, self->d);
      self->fn[F_COMPOS](self->m, self->d);
      self->fn[F_COMVEL](self->m, self->d);
      status = 0;
    }
  } else {
    status = 4;
  }
  forward_handler = saved;
  set_tls_handler(prev);
  memcpy(error_jump, outer, sizeof(jmp_buf));
  return status;
}

/* The fast-call methods' common head: nargs arguments, the first an integer, the second a
 * truth value. */
static int parse_int_flag(PyObject* const* args, Py_ssize_t nargs, Py_ssize_t want,
                          const char* usage, long* number, int* flag) {
  if (nargs != want) {
    PyErr_SetString(PyExc_TypeError, usage);
    return -1;
  }
  *number = PyLong_AsLong(args[0]);
  *flag = PyObject_IsTrue(args[1]);
  if ((*number == -1 && PyErr_Occurred()) || *flag < 0) return -1;
  return 0;
}

static int send_bound(Kernel* self); /* the bound commands, before a step (below) */

/* step(n, pending_torque) -> status: run_steps's, or 4 for a MuJoCo error (last_error() says
 * which). The GIL is released meanwhile: Sims in other threads step in parallel. */
static PyObject* Kernel_step(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  long n;
  int pending;
  if (refuse_if_busy(self) < 0 || parse_int_flag(args, nargs, 2, "step(n, pending_torque)", &n,
                                                 &pending) < 0)
    return NULL;
  if (self->n_bound && send_bound(self) < 0) return NULL; /* no step ran */
  int status;
  self->busy = 1;
  self->started++;
  self->interrupted = 0;
  Py_BEGIN_ALLOW_THREADS
  status = guarded(self, 0, n, pending);
  Py_END_ALLOW_THREADS
  self->busy = 0;
  /* a Python callback of MuJoCo's (mjcb_*) that raised: MuJoCo's bindings turn it into an
   * mju_error, which jumped back here; the callback's exception is the one to raise */
  if (PyErr_Occurred()) {
    self->interrupted = 1;
    return NULL;
  }
  return PyLong_FromLong(status);
}

/* check_idle() -> mark: raises the busy error while another thread steps this kernel; the
 * mark (step() calls begun) is for check_since() at the end of a read of several parts */
static PyObject* Kernel_check_idle(Kernel* self, PyObject* unused) {
  (void)unused;
  if (refuse_if_busy(self) < 0) return NULL;
  return PyLong_FromUnsignedLong(self->started);
}

/* check_since(mark): the busy error if a step() began since check_idle() gave ``mark`` (in
 * another thread, between two parts of a read: the parts would be of different steps) */
static PyObject* Kernel_check_since(Kernel* self, PyObject* mark) {
  unsigned long then = PyLong_AsUnsignedLong(mark);
  if (then == (unsigned long)-1 && PyErr_Occurred()) return NULL;
  if (refuse_if_busy(self) < 0) return NULL;
  if (then != self->started) {
    PyErr_SetString(busy_error ? busy_error : PyExc_RuntimeError,
                    "this Sim stepped in another thread while it was being read; a Sim takes "
                    "one call at a time (give each thread its own Sim)");
    return NULL;
  }
  Py_RETURN_NONE;
}

/* last_error() -> the text of the last MuJoCo error seen by this thread's kernel calls */
static PyObject* Kernel_last_error(Kernel* self, PyObject* unused) {
  (void)self;
  (void)unused;
  return PyUnicode_DecodeUTF8(error_text, (Py_ssize_t)strnlen(error_text, sizeof(error_text)),
                              "replace");
}

/* The 20 doubles of body_state for body ``bid`` into ``o``: centre-of-mass position,
 * orientation (x, y, z, w), world linear and angular velocity, link-frame position and
 * orientation (x, y, z, w). Returns 1 when the centre of mass's position is finite. */
static int write_body_state(Kernel* self, long bid, double* o) {
  const mjModel* m = self->m;
  mjData* d = self->d;
  double q[4], v[6];
  self->mat2quat(q, d->ximat + 9 * bid);
  self->objvel(m, d, mjOBJ_BODY, (int)bid, v, 0);
  const double* p = d->xipos + 3 * bid;
  const double* fp = d->xpos + 3 * bid;
  const double* fq = d->xquat + 4 * bid;
  double r[20] = {p[0], p[1], p[2], q[1], q[2], q[3], q[0], v[3], v[4], v[5], v[0], v[1], v[2],
                  fp[0], fp[1], fp[2], fq[1], fq[2], fq[3], fq[0]};
  int finite = 1;
  for (int i = 0; i < 20; i++) {
    o[i] = r[i];
    if (i < 3 && !isfinite(r[i])) finite = 0;
  }
  return finite;
}

/* body_state(body_id, fresh, out): out[0:20] = centre-of-mass position, orientation (x, y, z,
 * w), world linear and angular velocity, link-frame position and orientation (x, y, z, w);
 * with fresh, first mj_kinematics, mj_comPos, mj_comVel (the lazy refresh after a step).
 * Returns False when the pose is not finite, None when MuJoCo raised an error (last_error()). */
static PyObject* Kernel_body_state(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  long bid;
  int fresh;
  if (refuse_if_busy(self) < 0 ||
      parse_int_flag(args, nargs, 3, "body_state(body_id, fresh, out)", &bid, &fresh) < 0)
    return NULL;
  const mjModel* m = self->m;
  if (bid < 0 || bid >= m->nbody) {
    PyErr_Format(PyExc_ValueError, "body id %ld outside 0..%d", bid, (int)m->nbody - 1);
    return NULL;
  }
  Py_buffer out;
  if (PyObject_GetBuffer(args[2], &out, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0) return NULL;
  if (out.len != 20 * (Py_ssize_t)sizeof(double) || out.itemsize != sizeof(double)) {
    PyBuffer_Release(&out);
    PyErr_SetString(PyExc_ValueError, "out: a float64 array of 20");
    return NULL;
  }
  if (fresh && guarded(self, 1, 0, 0) == 4) {
    PyBuffer_Release(&out);
    if (PyErr_Occurred()) return NULL; /* a Python callback's exception, as in step() */
    Py_RETURN_NONE; /* a MuJoCo error: last_error() says which */
  }
  int finite = write_body_state(self, bid, (double*)out.buf);
  PyBuffer_Release(&out);
  return PyBool_FromLong(finite);
}

/* bodies_state(body_ids, fresh, out): body_state of each body of ``body_ids`` (a C-contiguous
 * array of C longs, np.intp on the platforms built for) into row k of ``out`` (a float64 array
 * of len(body_ids) x 20), in one call: the same floats as body_state, body by body. Returns
 * False when a pose is not finite, None when MuJoCo raised an error (last_error()). */
static PyObject* Kernel_bodies_state(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (nargs != 3) {
    PyErr_SetString(PyExc_TypeError, "bodies_state(body_ids, fresh, out)");
    return NULL;
  }
  int fresh = PyObject_IsTrue(args[1]);
  if (fresh < 0 || refuse_if_busy(self) < 0) return NULL;
  Py_buffer ids, out;
  if (PyObject_GetBuffer(args[0], &ids, PyBUF_C_CONTIGUOUS) < 0) return NULL;
  if (ids.itemsize != sizeof(long) || ids.len % (Py_ssize_t)sizeof(long)) {
    PyBuffer_Release(&ids);
    PyErr_SetString(PyExc_ValueError, "body_ids: an array of C longs (np.intp)");
    return NULL;
  }
  Py_ssize_t n = ids.len / (Py_ssize_t)sizeof(long);
  const long* bids = (const long*)ids.buf;
  const mjModel* m = self->m;
  for (Py_ssize_t k = 0; k < n; k++) {
    if (bids[k] < 0 || bids[k] >= m->nbody) {
      PyBuffer_Release(&ids);
      PyErr_Format(PyExc_ValueError, "body id %ld outside 0..%d", bids[k], (int)m->nbody - 1);
      return NULL;
    }
  }
  if (PyObject_GetBuffer(args[2], &out, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0) {
    PyBuffer_Release(&ids);
    return NULL;
  }
  if (out.len != 20 * n * (Py_ssize_t)sizeof(double) || out.itemsize != sizeof(double)) {
    PyBuffer_Release(&ids);
    PyBuffer_Release(&out);
    PyErr_SetString(PyExc_ValueError, "out: a float64 array of len(body_ids) x 20");
    return NULL;
  }
  if (fresh && guarded(self, 1, 0, 0) == 4) {
    PyBuffer_Release(&ids);
    PyBuffer_Release(&out);
    if (PyErr_Occurred()) return NULL; /* a Python callback's exception, as in step() */
    Py_RETURN_NONE; /* a MuJoCo error: last_error() says which */
  }
  double* o = (double*)out.buf;
  int finite = 1;
  for (Py_ssize_t k = 0; k < n; k++) finite &= write_body_state(self, bids[k], o + 20 * k);
  PyBuffer_Release(&ids);
  PyBuffer_Release(&out);
  return PyBool_FromLong(finite);
}

/* bind_commands(target_velocity, max_force[, target_position]): the motor table's command
 * arrays (one entry per motor), which the command writes below update with the rows. */
static PyObject* Kernel_bind_commands(Kernel* self, PyObject* args) {
  if (refuse_if_busy(self) < 0) return NULL;
  PyObject *tv, *mf, *tp = NULL;
  if (!PyArg_ParseTuple(args, "OO|O", &tv, &mf, &tp)) return NULL;
  if (arr_take(&self->cmd_target, tv, 'd', -1, "target_velocity") < 0) return NULL;
  if (arr_take(&self->cmd_force, mf, 'd', arr_len(&self->cmd_target), "max_force") < 0)
    return NULL;
  arr_release(&self->cmd_position);
  if (tp && arr_take(&self->cmd_position, tp, 'd', arr_len(&self->cmd_target),
                     "target_position") < 0)
    return NULL;
  Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- command writes
 * (commands.py's hot paths and the bound commands): the same arithmetic as MotorTable.refresh
 * and Compiled.refresh_motors, on motors whose rows are present and stay present (every force
 * > 0), so that a command written here leaves the table, the model and the rows exactly as the
 * full refresh would. Indices are checked (check_index) before the first write. */

/* index: nrow x n intp (slots, rows, dofs[, position rows]); 0, or -1 with ValueError */
static int check_index(const Kernel* self, const Py_ssize_t* ix, Py_ssize_t n, int position,
                       const char* what) {
  const Py_ssize_t* slot = ix;
  const Py_ssize_t* row = ix + n;
  const Py_ssize_t* dof = ix + 2 * n;
  const Py_ssize_t* prow = ix + 3 * n;
  const Py_ssize_t np_ = arr_len(&self->pos_rows);
  for (Py_ssize_t i = 0; i < n; i++) {
    int bad = slot[i] < 0 || slot[i] >= arr_len(&self->cmd_target) || row[i] < 0 ||
              row[i] >= self->k || dof[i] < 0 || dof[i] >= self->m->nv ||
              IP(self->dof_rows)[row[i]] != dof[i];
    if (position)
      bad = bad || arr_len(&self->cmd_position) != arr_len(&self->cmd_target) ||
            arr_len(&self->pos_target) != np_ || prow[i] < 0 || prow[i] >= np_ ||
            IP(self->pos_rows)[prow[i]] != row[i];
    if (bad) {
      PyErr_Format(PyExc_ValueError, "%s: a slot, row, dof or position row index out of range",
                   what);
      return -1;
    }
  }
  return 0;
}

/* A velocity command (kp 0, kd 1): offset kd v / dt with kd 1, slack f (1 - 1e-9). */
static void write_velocity(Kernel* self, const Py_ssize_t* ix, Py_ssize_t n, const double* v,
                           const double* f) {
  const Py_ssize_t *slot = ix, *row = ix + n, *dof = ix + 2 * n;
  double* frictionloss = ((mjModel*)self->m)->dof_frictionloss;
  for (Py_ssize_t i = 0; i < n; i++) {
    DP(self->cmd_target)[slot[i]] = v[i];
    DP(self->cmd_force)[slot[i]] = f[i];
    frictionloss[dof[i]] = f[i];
    DP(self->offset)[row[i]] = v[i] / self->dt;
    DP(self->slack)[row[i]] = f[i] * (1.0 - 1e-9);
  }
}

/* A position command on motors already in position mode with the same kp and kd (target
 * velocity 0): the target clamped to [lo, hi] as PyBullet does (Python's min(max(q, lo), hi)),
 * offset 0 + gain q (refresh's kd 0 / dt, then += gain q), slack f (1 - 1e-9). */
static void write_position(Kernel* self, const Py_ssize_t* ix, const double* lohi, Py_ssize_t n,
                           const double* target, const double* f) {
  const Py_ssize_t *slot = ix, *row = ix + n, *dof = ix + 2 * n, *prow = ix + 3 * n;
  double* frictionloss = ((mjModel*)self->m)->dof_frictionloss;
  for (Py_ssize_t i = 0; i < n; i++) {
    double q = target[i];
    if (lohi[i] > q) q = lohi[i];
    if (lohi[n + i] < q) q = lohi[n + i];
    DP(self->cmd_position)[slot[i]] = q;
    DP(self->cmd_force)[slot[i]] = f[i];
    frictionloss[dof[i]] = f[i];
    DP(self->pos_target)[prow[i]] = q;
    DP(self->offset)[row[i]] = 0.0 + DP(self->pos_gain)[prow[i]] * q;
    DP(self->slack)[row[i]] = f[i] * (1.0 - 1e-9);
  }
}

/* Two lists of n exact Python floats into buf (2 x n): 0, or -1 with an exception. Exact
 * floats (what Sim's checks produce): reading them runs no Python code. */
static int read_lists(PyObject* a, PyObject* b, Py_ssize_t n, double* buf, const char* what) {
  if (!PyList_Check(a) || !PyList_Check(b) || PyList_Size(a) != n ||
      PyList_Size(b) != n) {
    PyErr_Format(PyExc_ValueError, "%s: two lists of n floats (n = %zd)", what, n);
    return -1;
  }
  for (Py_ssize_t i = 0; i < n; i++) {
    PyObject *x = PyList_GetItem(a, i), *y = PyList_GetItem(b, i);
    if (!PyFloat_CheckExact(x) || !PyFloat_CheckExact(y)) {
      PyErr_Format(PyExc_TypeError, "%s: the lists hold Python floats", what);
      return -1;
    }
    buf[i] = PyFloat_AsDouble(x);
    buf[n + i] = PyFloat_AsDouble(y);
  }
  return 0;
}

/* set_velocity(index, target, max_force) and set_position(index, limits, target, max_force):
 * a command on motors whose rows are present (MotorCommands' hot paths): index 3 x n (slots,
 * rows, dofs) or 4 x n (+ rows in the position arrays), limits 2 x n float64 (lower, upper),
 * target and max_force lists of n floats (max_force > 0). Everything is checked before the
 * first write. */
static PyObject* command_write(Kernel* self, PyObject* const* args, Py_ssize_t nargs,
                               int position) {
  const char* what = position ? "set_position" : "set_velocity";
  if (refuse_if_busy(self) < 0) return NULL;
  if (nargs != 3 + position) {
    PyErr_SetString(PyExc_TypeError, position ? "set_position(index, limits, target, max_force)"
                                              : "set_velocity(index, target, max_force)");
    return NULL;
  }
  const int nrow = 3 + position;
  Arr ix = {.held = 0}, lim = {.held = 0};
  double small[128];
  double* buf = small;
  PyObject* result = NULL;
  if (arr_take(&ix, args[0], 'n', -1, "index") < 0) return NULL;
  Py_ssize_t n = arr_len(&ix) / nrow;
  if (arr_len(&ix) != nrow * n) {
    PyErr_Format(PyExc_ValueError, "%s: a %d x n index", what, nrow);
    goto done;
  }
  if (position && arr_take(&lim, args[1], 'd', 2 * n, "limits") < 0) goto done;
  if (2 * n > 128 && !(buf = PyMem_Malloc(2 * (size_t)n * sizeof(double)))) {
    PyErr_NoMemory();
    goto done;
  }
  if (read_lists(args[1 + position], args[2 + position], n, buf, what) < 0 ||
      check_index(self, IP(ix), n, position, what) < 0)
    goto done;
  if (position)
    write_position(self, IP(ix), DP(lim), n, buf, buf + n);
  else
    write_velocity(self, IP(ix), n, buf, buf + n);
  result = Py_None;
  Py_INCREF(result);
done:
  if (buf != small) PyMem_Free(buf);
  arr_release(&ix);
  arr_release(&lim);
  return result;
}

static PyObject* Kernel_set_velocity(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  return command_write(self, args, nargs, 0);
}

static PyObject* Kernel_set_position(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  return command_write(self, args, nargs, 1);
}

/* add_torque(slots, torque): torque commands for the next step, added to the pending ones
 * (tq[slot] += torque, as numpy's torque[slots] += torque); slots intp, torque a list of
 * Python floats. */
static PyObject* Kernel_add_torque(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (refuse_if_busy(self) < 0) return NULL;
  if (nargs != 2) {
    PyErr_SetString(PyExc_TypeError, "add_torque(slots, torque)");
    return NULL;
  }
  Arr ix = {.held = 0};
  if (arr_take(&ix, args[0], 'n', -1, "slots") < 0) return NULL;
  Py_ssize_t n = arr_len(&ix);
  PyObject* tl = args[1];
  int ok = PyList_Check(tl) && PyList_Size(tl) == n;
  for (Py_ssize_t i = 0; ok && i < n; i++)
    ok = IP(ix)[i] >= 0 && IP(ix)[i] < arr_len(&self->tq) && PyFloat_CheckExact(PyList_GetItem(tl, i));
  if (!ok) {
    arr_release(&ix);
    PyErr_SetString(PyExc_ValueError, "add_torque: slots in range and a list of as many floats");
    return NULL;
  }
  for (Py_ssize_t i = 0; i < n; i++) DP(self->tq)[IP(ix)[i]] += PyFloat_AsDouble(PyList_GetItem(tl, i));
  arr_release(&ix);
  Py_RETURN_NONE;
}

/* ---------------------------------------------------------------- bound commands */

static Bound* bound_of(Kernel* self, PyObject* handle) {
  long h = PyLong_AsLong(handle);
  if (h == -1 && PyErr_Occurred()) return NULL;
  if (h < 0 || h >= self->n_bound || !self->bound[h].used) {
    PyErr_Format(PyExc_ValueError, "no bound command %ld", h);
    return NULL;
  }
  return &self->bound[h];
}

/* add_command(position, targets, max_force, resend) -> handle: bind a command's arrays
 * (float64, n each), taken as sent (the caller sent them); disarmed until arm_command. */
static PyObject* Kernel_add_command(Kernel* self, PyObject* args) {
  if (refuse_if_busy(self) < 0) return NULL;
  int position;
  PyObject *t, *f, *resend;
  if (!PyArg_ParseTuple(args, "pOOO", &position, &t, &f, &resend)) return NULL;
  if (!PyCallable_Check(resend)) {
    PyErr_SetString(PyExc_TypeError, "add_command: resend must be callable");
    return NULL;
  }
  int h = 0;
  while (h < self->n_bound && self->bound[h].used) h++;
  if (h == self->n_bound) {
    Bound* grown = PyMem_Realloc(self->bound, (size_t)(self->n_bound + 1) * sizeof(Bound));
    if (!grown) return PyErr_NoMemory();
    self->bound = grown;
    memset(&self->bound[h], 0, sizeof(Bound));
    self->n_bound++;
  }
  Bound* b = &self->bound[h];
  if (arr_take(&b->targets, t, 'd', -1, "targets") < 0) goto fail;
  b->n = arr_len(&b->targets);
  if (arr_take(&b->force, f, 'd', b->n, "max_force") < 0) goto fail;
  b->last = PyMem_Malloc(2 * (size_t)(b->n ? b->n : 1) * sizeof(double));
  if (!b->last) {
    PyErr_NoMemory();
    goto fail;
  }
  memcpy(b->last, DP(b->targets), (size_t)b->n * sizeof(double));
  memcpy(b->last + b->n, DP(b->force), (size_t)b->n * sizeof(double));
  Py_INCREF(resend);
  b->resend = resend;
  b->position = position;
  b->used = 1;
  b->armed = b->stale = 0;
  return PyLong_FromLong(h);
fail:
  bound_clear(b);
  return NULL;
}

/* arm_command(handle, index, limits): the command was just sent (through Python): its arrays
 * are what is in force. index (3 or 4 x n intp, as set_velocity / set_position) arms it: its
 * next changes are written here; None leaves it to the Python path (rows absent, say). */
static PyObject* Kernel_arm_command(Kernel* self, PyObject* const* args, Py_ssize_t nargs) {
  if (refuse_if_busy(self) < 0) return NULL;
  if (nargs != 3) {
    PyErr_SetString(PyExc_TypeError, "arm_command(handle, index, limits)");
    return NULL;
  }
  Bound* b = bound_of(self, args[0]);
  if (!b) return NULL;
  Py_ssize_t n = b->n;
  b->armed = 0;
  arr_release(&b->index);
  arr_release(&b->limits);
  if (args[1] != Py_None) {
    if (arr_take(&b->index, args[1], 'n', (3 + b->position) * n, "index") < 0 ||
        (b->position && arr_take(&b->limits, args[2], 'd', 2 * n, "limits") < 0) ||
        check_index(self, IP(b->index), n, b->position, "arm_command") < 0) {
      arr_release(&b->index);
      arr_release(&b->limits);
      return NULL;
    }
    b->armed = 1;
  }
  b->stale = 0;
  memcpy(b->last, DP(b->targets), (size_t)n * sizeof(double));
  memcpy(b->last + n, DP(b->force), (size_t)n * sizeof(double));
  Py_RETURN_NONE;
}

/* remove_command(handle): unbind (the motors keep the command last sent) */
static PyObject* Kernel_remove_command(Kernel* self, PyObject* handle) {
  if (refuse_if_busy(self) < 0) return NULL;
  Bound* b = bound_of(self, handle);
  if (!b) return NULL;
  bound_clear(b);
  Py_RETURN_NONE;
}

/* Before a step() call, with the GIL: each bound command whose arrays changed since they were
 * last sent (by value, as Python's ==) is written here when it is armed and every value is
 * finite with a force > 0, and otherwise sent through its Python path (which checks the
 * values, raising on a bad one, and arms it again); a disarmed (stale) command is sent through
 * Python whether it changed or not. 0, or -1 with the Python path's exception. */
static int send_bound(Kernel* self) {
  for (int h = 0; h < self->n_bound; h++) {
    Bound* b = &self->bound[h];
    if (!b->used) continue;
    const Py_ssize_t n = b->n;
    const double *t = DP(b->targets), *f = DP(b->force), *last = b->last;
    int changed = b->stale, fast = b->armed && !b->stale;
    for (Py_ssize_t i = 0; i < n && !changed; i++)
      changed = t[i] != last[i] || f[i] != last[n + i];
    if (!changed) continue;
    for (Py_ssize_t i = 0; i < n && fast; i++)
      fast = isfinite(t[i]) && isfinite(f[i]) && f[i] > 0.0;
    if (fast) {
      if (b->position)
        write_position(self, IP(b->index), DP(b->limits), n, t, f);
      else
        write_velocity(self, IP(b->index), n, t, f);
      memcpy(b->last, t, (size_t)n * sizeof(double));
      memcpy(b->last + n, f, (size_t)n * sizeof(double));
      continue;
    }
    PyObject* resend = b->resend;
    Py_INCREF(resend); /* the call may unbind it */
    PyObject* r = PyObject_CallNoArgs(resend);
    Py_DECREF(resend);
    if (!r) return -1;
    Py_DECREF(r);
  }
  return 0;
}

#ifdef SIMBRIDGE_KERNEL_TIMERS
/* timers() -> nanoseconds spent in each phase since the last call (and reset them) */
static PyObject* Kernel_timers(Kernel* self, PyObject* unused) {
  PyObject* out = PyList_New(N_TIMERS);
  if (!out) return NULL;
  for (int i = 0; i < N_TIMERS; i++) {
    PyObject* t = PyFloat_FromDouble(timers[i]);
    if (!t || PyList_SetItem(out, i, t) < 0) {  /* SetItem takes t, even on failure */
      Py_DECREF(out);
      return NULL;
    }
    timers[i] = 0.0;
  }
  return out;
}
#endif

static PyMethodDef Kernel_methods[] = {
#ifdef SIMBRIDGE_KERNEL_TIMERS
    {"timers", (PyCFunction)Kernel_timers, METH_NOARGS, "phase times in ns, then reset"},
#endif
    {"bind_world", (PyCFunction)Kernel_bind_world, METH_VARARGS, "Bind the world's arrays."},
    {"bind_motors", (PyCFunction)Kernel_bind_motors, METH_VARARGS, "Bind the motor rows."},
    {"step", (PyCFunction)(void (*)(void))Kernel_step, METH_FASTCALL, "step(n, pending_torque)"},
    {"last_error", (PyCFunction)Kernel_last_error, METH_NOARGS, "the last MuJoCo error's text"},
    {"check_idle", (PyCFunction)Kernel_check_idle, METH_NOARGS,
     "raise the busy error while another thread steps this kernel; else the step mark"},
    {"check_since", (PyCFunction)Kernel_check_since, METH_O,
     "raise the busy error if a step began since check_idle() gave this mark"},
    {"bind_commands", (PyCFunction)Kernel_bind_commands, METH_VARARGS,
     "Bind the motor table's command arrays."},
    {"set_velocity", (PyCFunction)(void (*)(void))Kernel_set_velocity, METH_FASTCALL,
     "set_velocity(index, target, max_force): a velocity command on present rows"},
    {"bind_balls", (PyCFunction)Kernel_bind_balls, METH_VARARGS,
     "bind_balls(rows, error_index, gain, qadr, target): the spherical position motors"},
    {"set_position", (PyCFunction)(void (*)(void))Kernel_set_position, METH_FASTCALL,
     "set_position(index, limits, target, max_force): a position command on present rows"},
    {"add_torque", (PyCFunction)(void (*)(void))Kernel_add_torque, METH_FASTCALL,
     "add_torque(slots, torque): torques for the next step, added"},
    {"add_command", (PyCFunction)Kernel_add_command, METH_VARARGS,
     "add_command(position, targets, max_force, resend) -> handle: bind a command's arrays"},
    {"arm_command", (PyCFunction)(void (*)(void))Kernel_arm_command, METH_FASTCALL,
     "arm_command(handle, index, limits): the command was sent; write its changes here"},
    {"remove_command", (PyCFunction)Kernel_remove_command, METH_O,
     "remove_command(handle): unbind a command"},
    {"body_state", (PyCFunction)(void (*)(void))Kernel_body_state, METH_FASTCALL,
     "body_state(body_id, fresh, out) -> pose is finite"},
    {"bodies_state", (PyCFunction)(void (*)(void))Kernel_bodies_state, METH_FASTCALL,
     "bodies_state(body_ids, fresh, out) -> every pose is finite"},
    {NULL, NULL, 0, NULL},
};

static PyObject* Kernel_done(Kernel* self, void* closure) {
  (void)closure;
  return PyLong_FromLong(self->done);
}

static PyObject* Kernel_interrupted(Kernel* self, void* closure) {
  (void)closure;
  return PyBool_FromLong(self->interrupted);
}

static PyGetSetDef Kernel_getset[] = {
    {"interrupted", (getter)Kernel_interrupted, NULL,
     "the last step() stopped mid-step on a Python callback's exception", NULL},
    {"steps_done", (getter)Kernel_done, NULL, "steps completed by the last step() call", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyType_Slot Kernel_slots[] = {
    {Py_tp_doc, "The MuJoCo backend's step loop (see backends/_mjkernel.c)."},
    {Py_tp_new, PyType_GenericNew},
    {Py_tp_init, (initproc)Kernel_init},
    {Py_tp_dealloc, (destructor)Kernel_dealloc},
    {Py_tp_methods, Kernel_methods},
    {Py_tp_getset, Kernel_getset},
    {0, NULL},
};
static PyType_Spec Kernel_spec = {"simbridge.backends._mjkernel.Kernel", sizeof(Kernel), 0,
                                  Py_TPFLAGS_DEFAULT, Kernel_slots};


static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_mjkernel", "The MuJoCo backend's step loop in C.", -1,
    module_methods,
};

/* The MuJoCo release whose headers this was compiled against, as its wheel names it: setup.py
 * defines it from the build environment's mujoco (kernel.py shows it beside the one running). */
#ifndef SIMBRIDGE_MUJOCO_RELEASE
#define SIMBRIDGE_MUJOCO_RELEASE "unknown"
#endif

PyMODINIT_FUNC PyInit__mjkernel(void) {
  PyObject* kernel_type = PyType_FromSpec(&Kernel_spec);
  if (!kernel_type) return NULL;
  PyObject* mod = PyModule_Create(&module);
  if (!mod) return NULL;
  if (PyModule_AddObject(mod, "Kernel", kernel_type) < 0 ||
      PyModule_AddIntConstant(mod, "HEADER_VERSION", mjVERSION_HEADER) < 0 ||
      PyModule_AddStringConstant(mod, "MUJOCO_RELEASE", SIMBRIDGE_MUJOCO_RELEASE) < 0 ||
      PyModule_AddIntConstant(mod, "LIMIT_RULES", 1) < 0 ||
      PyModule_AddIntConstant(mod, "SIZEOF_MJDATA", (long)sizeof(mjData)) < 0 ||
      PyModule_AddIntConstant(mod, "SIZEOF_MJMODEL", (long)sizeof(mjModel)) < 0) {
    Py_DECREF(mod);
    return NULL;
  }
  return mod;
}
