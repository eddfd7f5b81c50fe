/* The servo loop's PD ticks in C: the compiled twin of sim/servo_loop.py's ServoLoop._pd_ticks.
 *
 * Per servo tick k: record qpos (the state at t_k); x_k = qpos[adr] * mm_per_m (the encoders,
 * joint coordinates [mm]); u = b_k - a x_k + c x_{k-1}; F = clamp(u, lo, hi) (the law of
 * gantry_sim.controller.servo.DiscretePD.force, the same operations in the same order);
 * ctrl[act] = F * inv_gear; then `nsub` calls of mj_step with the force held. IEEE doubles,
 * built with -ffp-contract=off (no fused multiply-add): every number equals the Python loop's
 * bit for bit (tests/test_pd_ticks.py checks qpos and forces on a moving run).
 *
 * MuJoCo is not linked: sim/pd_ticks.py passes the address of the mj_step the Python bindings
 * use (the same loaded libmujoco) and the raw mjModel / mjData / qpos / ctrl pointers.
 *
 * MuJoCo reports a fatal error (mju_error) through the global handler mju_user_error when no
 * thread-local handler is active, as in a call that does not come from the Python bindings.
 * gantry_install_error_handler puts ours there (only where none was set): inside
 * gantry_pd_ticks it jumps back and the call returns 1 with the message (the Python side raises
 * mujoco.FatalError, as the bindings' mj_step does); anywhere else it prints and exits, as
 * MuJoCo's default does (without waiting for Enter).
 *
 * It is also a (method-less) Python extension module, so that setuptools builds it as one and
 * Python finds the file by importing it; the work is done through ctypes.
 */
#include <Python.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#if defined(_MSC_VER)
#define THREAD_LOCAL __declspec(thread)
#define EXPORT __declspec(dllexport)
#else
#define THREAD_LOCAL _Thread_local
#define EXPORT __attribute__((visibility("default")))
#endif

typedef void (*step_fn)(const void *model, void *data);
typedef void (*error_fn)(const char *msg);

static THREAD_LOCAL jmp_buf *active_jump = NULL;
static THREAD_LOCAL char error_message[1024];

static void on_mujoco_error(const char *msg) {
  if (active_jump != NULL) {
    strncpy(error_message, msg, sizeof(error_message) - 1);
    error_message[sizeof(error_message) - 1] = '\0';
    longjmp(*active_jump, 1);
  }
  fprintf(stderr, "ERROR: %s\n", msg);
  exit(EXIT_FAILURE);
}

/* Put our handler in MuJoCo's global error slot unless one is set there. Returns 1 if the slot
 * now holds ours. */
EXPORT int gantry_install_error_handler(error_fn *slot) {
  if (*slot == NULL) {
    *slot = on_mujoco_error;
  }
  return *slot == on_mujoco_error;
}

/* The message of the last fatal error caught in this thread. */
EXPORT const char *gantry_last_error(void) { return error_message; }

/* Run n ticks. Arguments:
 *   step, model, data: mj_step and its arguments;
 *   qpos (nq), ctrl: the mjData's arrays; adr[3] qpos address, act[3] actuator id per axis;
 *   nsub: physics steps per tick; n: ticks;
 *   b (n x 3): drive terms b_k [N]; coef[16]: a[3], c[3], lo[3], hi[3], inv_gear[3], mm_per_m;
 *   enc (3): in, x_{-1} of this range [mm]; out, the last tick's encoders [mm];
 *   qpos_out (n x nq): the recorded states; force_out (n x 3): the held forces [N].
 * Returns 0, or 1 when MuJoCo raised a fatal error (gantry_last_error says which). */
EXPORT int gantry_pd_ticks(step_fn step, const void *model, void *data, const double *qpos,
                           double *ctrl, const long *adr, const long *act, int nq, int nsub,
                           long n, const double *b, const double *coef, double *enc,
                           double *qpos_out, double *force_out) {
  jmp_buf jump;
  jmp_buf *outer = active_jump;
  const double mm = coef[15];
  double prev[3] = {enc[0], enc[1], enc[2]};
  if (setjmp(jump) != 0) {
    active_jump = outer;
    return 1;
  }
  active_jump = &jump;
  for (long k = 0; k < n; k++) {
    double *row = qpos_out + k * nq;
    for (int j = 0; j < nq; j++) {
      row[j] = qpos[j];
    }
    for (int i = 0; i < 3; i++) {
      const double x = row[adr[i]] * mm;
      double f = b[3 * k + i] - coef[i] * x + coef[3 + i] * prev[i];
      const double lo = coef[6 + i], hi = coef[9 + i];
      f = f > hi ? hi : (f < lo ? lo : f);
      ctrl[act[i]] = f * coef[12 + i];
      force_out[3 * k + i] = f;
      prev[i] = x;
    }
    for (int s = 0; s < nsub; s++) {
      step(model, data);
    }
  }
  active_jump = outer;
  enc[0] = prev[0];
  enc[1] = prev[1];
  enc[2] = prev[2];
  return 0;
}

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "_pd_ticks",
                                    "Compiled servo ticks, used through ctypes (sim/pd_ticks.py).",
                                    -1, NULL};

PyMODINIT_FUNC PyInit__pd_ticks(void) { return PyModule_Create(&module); }
