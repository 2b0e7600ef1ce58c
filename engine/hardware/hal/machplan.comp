// machplan's side of the servo thread: the pins a machine's HAL file nets to its hardware, the
// exchange with the machplan program (exchange_block.h) and the watchdog that stops the machine
// when the program stops answering. Built and installed by scripts/setup:
//
//     halcompile --install engine/hardware/hal/machplan.comp
//
// and used as
//
//     loadrt machplan
//     addf machplan servo-thread      # after the hardware's read functions, before its writes
//
// Every period the function (1) opens or closes a session when the program asks, (2) takes the
// command the program wrote for this period, or counts the period as missed and plays the
// position the program planned for it (when it wrote one ahead) or coasts, (3)
// trips the watchdog after more than `watchdog-periods` missed periods in a row while the
// drives or the torch are on, (4) gates the outputs with the E-stop chain, the operator's
// E-stop and the watchdog, and (5) publishes the input pins as this period's sample. It never
// waits for the program. See docs/hal.md for the whole protocol, the wiring, and which of
// QtPlasmaC's plasmac pins each pin stands for (the probing and operator pins take plasmac's
// names where it has one).
component machplan "machplan's exchange with the servo thread, and its watchdog";
option singleton yes;
option extra_setup yes;
option extra_cleanup yes;

pin out float axis.#.pos-cmd [2] "position command, mm (position mode; follows pos-fb when idle and in velocity mode)";
pin in float axis.#.pos-fb [2] "position feedback, mm (position mode)";
pin out bit axis.#.enable [2] "this axis's drive enabled";
pin out float axis.#.vel-cmd [2] "speed command, mm/s at the drive's nominal scaling (velocity mode)";
pin in s32 axis.#.counts [2] "raw encoder counts, up for positive motion (velocity mode)";
pin out bit enable "drives on";
pin out bit torch-on "torch on (plasma: start and hold the arc; oxy-fuel: cutting oxygen)";
pin in bit arc-ok "the plasma source reports a transferred arc";
pin out float torch-height-cmd "where the torch height axis must be, mm in the machine's height frame (0: the sheet's nominal surface, up positive)";
pin in float torch-height-fb "the torch height axis's position, mm in the same frame";
pin in float arc-voltage "arc voltage, V (for THC; passed through the exchange)";
pin in bit estop-ok "the E-stop chain is closed; FALSE drops torch-on, ohmic-enable and enable in the same period";
pin out bit ohmic-enable "ohmic sensing on: energise the torch's shield so that touching the plate closes ohmic-sense-in (gated like torch-on by the E-stop chain, the operator's E-stop and the watchdog)";
pin out bit laser-on "the laser pointer on while machplan frames a job with it (gated like torch-on)";
pin out bit offset-probe "deploy the offset probe (a probe beside the torch, its contact wired to float-switch) while machplan probes with it (gated like torch-on)";
pin in bit ohmic-sense-in "the ohmic contact is made: with ohmic-enable on, the torch's shield touches the plate";
pin in bit float-switch "the float switch is closed: the torch rests on something and its floating mount has risen by the switch's travel";
pin in bit breakaway "the torch's breakaway switch is open: the torch met something and its mount gave way (a collision)";
pin in float jog.# [2] "joystick deflection per axis, -1 .. 1";
pin in bit feed-hold "feed hold button";
pin in bit cycle-start "cycle start button";
pin in float feed-override = 100.0 "feed override, percent";
pin in bit stop "stop button: end the job with a controlled stop, torch off (rising edge)";
pin in float rapid-override = 100.0 "rapid override, percent of the planned speed, 1 .. 100";
pin in float cut-recovery-distance "cut recovery: the total distance asked along the executed path, mm (negative: backwards); a counter, each change is a request of that many mm";
pin in float paused-motion-speed "paused motion while the job is held: move along the program's path at this fraction (-1 .. 1, negative: back) of the machine's paused-motion speed, until it is 0 again";
pin in bit thc-enable = TRUE "torch height control allowed";
pin in bit torch-enable = TRUE "the torch may fire: FALSE runs the job dry (pierces skipped), and holds a cut under way";
pin in bit operator-estop "the operator's E-stop (a panel's, a pendant's) is open, a level; TRUE drops torch-on, ohmic-enable and enable in the same period like estop-ok FALSE";
pin out bit watchdog-ok = TRUE "FALSE from a watchdog trip until watchdog-reset or the next session";
pin out u32 period-count "periods this function has run";
pin out u32 missed-periods "periods in a row without a command in time";
pin out s32 state "0 idle, 1 armed (session open, no command yet), 2 running, 3 tripped";
pin in bit watchdog-reset "a rising edge clears a watchdog trip";

param rw bit velocity-mode = FALSE "FALSE: the drives close their own position loop (pos-cmd, pos-fb); TRUE: velocity-mode drives (vel-cmd, counts)";
param rw u32 watchdog-periods = 50 "missed periods in a row after which the watchdog trips (1 .. 200)";
param rw float stop-decel = 0.0 "mm/s^2: without commands the axes' speed falls at this rate, and after a trip ramps to rest; 0: keep the speed while commands are late, hold at once after a trip";

function _;
license "GPL";
author "machplan";
;;

#include <rtapi_math.h>
#include <rtapi_string.h>

#include "exchange_block.h"

static machplan_exchange_block *X;
static int shmem_id = -1;
static uint32_t count_, session_, missed_, flags_;
static int state_ = MACHPLAN_STATE_IDLE, estop_latched_, op_estop_latched_, reset_prev_;
static double pos_[MACHPLAN_HAL_AXES], vel_[MACHPLAN_HAL_AXES], height_;

EXTRA_SETUP() {
  shmem_id = rtapi_shmem_new(MACHPLAN_EXCHANGE_KEY, comp_id, sizeof(machplan_exchange_block));
  if (shmem_id < 0) return shmem_id;
  int r = rtapi_shmem_getptr(shmem_id, (void **)&X);
  if (r < 0) return r;
  memset(X, 0, sizeof(*X));
  X->version = MACHPLAN_EXCHANGE_VERSION;
  __atomic_store_n(&X->magic, MACHPLAN_EXCHANGE_MAGIC, __ATOMIC_RELEASE);
  return 0;
}

EXTRA_CLEANUP() {
  if (X) __atomic_store_n(&X->magic, 0u, __ATOMIC_RELEASE);  // a program still attached sees it go
  if (shmem_id >= 0) rtapi_shmem_delete(shmem_id, comp_id);
  X = 0;
}

// The command written for period `p` of session `s`, if it is complete.
static int take_command(machplan_exchange_block *x, uint32_t p, uint32_t s, machplan_command *c) {
  machplan_command *slot = &x->command[p % MACHPLAN_RING];
  uint32_t q1 = __atomic_load_n(&slot->seq, __ATOMIC_ACQUIRE);
  if (q1 & 1u) return 0;
  *c = *slot;
  __atomic_thread_fence(__ATOMIC_ACQUIRE);
  uint32_t q2 = __atomic_load_n(&slot->seq, __ATOMIC_RELAXED);
  return q1 == q2 && c->period == p && c->session == s;
}

// No command this period: the speed falls by stop-decel (along the path: every axis in
// proportion), or is kept when stop-decel is 0 unless `hold` asks to stop at once.
static void coast(double decel, double dt, int hold) {
  int i;
  double speed = 0, keep;
  for (i = 0; i < MACHPLAN_HAL_AXES; ++i) speed += vel_[i] * vel_[i];
  speed = sqrt(speed);
  if (decel > 0) keep = speed > decel * dt ? (speed - decel * dt) / speed : 0.0;
  else keep = hold ? 0.0 : 1.0;
  for (i = 0; i < MACHPLAN_HAL_AXES; ++i) {
    vel_[i] *= keep;
    pos_[i] += vel_[i] * dt;
  }
}

FUNCTION(_) {
  machplan_exchange_block *x = X;
  const double dt = fperiod;
  const int velocity = velocity_mode;
  machplan_command c;
  machplan_sample *s;
  const uint32_t watchdog = watchdog_periods < 1 ? 1 : watchdog_periods > 200 ? 200 : watchdog_periods;
  uint32_t p = ++count_, flags = 0, q, sess;
  int i, fresh = 0, ahead = 0, on, torch, ohmic, laser, probe;

  // 1. sessions
  sess = x ? __atomic_load_n(&x->session, __ATOMIC_ACQUIRE) : session_;
  if (sess != session_) {
    session_ = sess;
    state_ = MACHPLAN_STATE_ARMED;
    missed_ = 0;
    estop_latched_ = 0;
    op_estop_latched_ = 0;
    if (x) __atomic_store_n(&x->session_ack, sess, __ATOMIC_RELEASE);
  }
  if ((state_ == MACHPLAN_STATE_ARMED || state_ == MACHPLAN_STATE_RUNNING) && x &&
      __atomic_load_n(&x->closed, __ATOMIC_ACQUIRE) == session_)
    state_ = MACHPLAN_STATE_IDLE;
  if (watchdog_reset && !reset_prev_ && state_ == MACHPLAN_STATE_TRIPPED) state_ = MACHPLAN_STATE_IDLE;
  reset_prev_ = watchdog_reset;
  if (!estop_ok) estop_latched_ = 1;
  if (operator_estop) op_estop_latched_ = 1;
  if (state_ == MACHPLAN_STATE_IDLE) {
    estop_latched_ = !estop_ok;
    op_estop_latched_ = operator_estop;
  }

  // 2. this period's command, 3. the watchdog
  if (x && (state_ == MACHPLAN_STATE_ARMED || state_ == MACHPLAN_STATE_RUNNING))
    fresh = take_command(x, p, session_, &c);
  if (state_ == MACHPLAN_STATE_ARMED && fresh) state_ = MACHPLAN_STATE_RUNNING;
  if (state_ == MACHPLAN_STATE_RUNNING && fresh && (c.flags & MACHPLAN_CMD_AHEAD)) {
    // The program is late, but planned this period: the axes go where it planned them; the
    // outputs, the torch height and the watchdog take it as a missed period.
    fresh = 0;
    if (velocity) {
      ahead = 0;  /* never written in velocity mode: coast as below */
    } else {
      for (i = 0; i < MACHPLAN_HAL_AXES; ++i) {
        vel_[i] = (c.pos_mm[i] - pos_[i]) / dt;
        pos_[i] = c.pos_mm[i];
      }
      ahead = 1;
    }
  }
  if (state_ == MACHPLAN_STATE_RUNNING) {
    if (fresh) {
      for (i = 0; i < MACHPLAN_HAL_AXES; ++i) {
        if (velocity) {
          vel_[i] = c.vel_mm_per_s[i];
        } else {
          vel_[i] = (c.pos_mm[i] - pos_[i]) / dt;
          pos_[i] = c.pos_mm[i];
        }
      }
      height_ = c.height_mm;
      flags_ = c.flags;
      missed_ = 0;
    } else {
      ++missed_;
      if (!ahead) coast(stop_decel, dt, 0);
      if (missed_ > watchdog && (flags_ & (MACHPLAN_CMD_ENABLE | MACHPLAN_CMD_TORCH))) {
        state_ = MACHPLAN_STATE_TRIPPED;
        flags_ = 0;
      }
    }
  } else if (state_ == MACHPLAN_STATE_TRIPPED) {
    ++missed_;
    coast(stop_decel, dt, 1);
  } else {  // idle, armed: nothing moves, the commands stand where the axes are
    for (i = 0; i < MACHPLAN_HAL_AXES; ++i) {
      pos_[i] = axis_pos_fb(i);
      vel_[i] = 0.0;
    }
    height_ = torch_height_fb;
    flags_ = 0;
  }

  // 4. outputs, gated by the E-stop chain, the operator's E-stop and the watchdog (a trip
  // leaves the state, and flags_ is cleared)
  on = state_ == MACHPLAN_STATE_RUNNING && !estop_latched_ && !op_estop_latched_ && (flags_ & MACHPLAN_CMD_ENABLE);
  torch = state_ == MACHPLAN_STATE_RUNNING && !estop_latched_ && !op_estop_latched_ && (flags_ & MACHPLAN_CMD_TORCH);
  ohmic = state_ == MACHPLAN_STATE_RUNNING && !estop_latched_ && !op_estop_latched_ && (flags_ & MACHPLAN_CMD_OHMIC);
  laser = state_ == MACHPLAN_STATE_RUNNING && !estop_latched_ && !op_estop_latched_ && (flags_ & MACHPLAN_CMD_LASER);
  probe = state_ == MACHPLAN_STATE_RUNNING && !estop_latched_ && !op_estop_latched_ && (flags_ & MACHPLAN_CMD_PROBE);
  for (i = 0; i < MACHPLAN_HAL_AXES; ++i) {
    axis_pos_cmd(i) = velocity ? axis_pos_fb(i) : pos_[i];
    axis_vel_cmd(i) = velocity && (state_ == MACHPLAN_STATE_RUNNING || state_ == MACHPLAN_STATE_TRIPPED) ? vel_[i] : 0.0;
    axis_enable(i) = on;
  }
  enable = on;
  torch_on = torch;
  ohmic_enable = ohmic;
  laser_on = laser;
  offset_probe = probe;
  torch_height_cmd = height_;
  watchdog_ok = state_ != MACHPLAN_STATE_TRIPPED;
  period_count = p;
  missed_periods = missed_;
  state = state_;

  // 5. this period's sample
  if (!x) return;
  if (arc_ok) flags |= MACHPLAN_IN_ARC_OK;
  if (estop_latched_) flags |= MACHPLAN_IN_ESTOP;
  if (state_ == MACHPLAN_STATE_TRIPPED) flags |= MACHPLAN_IN_WATCHDOG;
  if (feed_hold) flags |= MACHPLAN_IN_FEED_HOLD;
  if (cycle_start) flags |= MACHPLAN_IN_CYCLE_START;
  if (fresh) flags |= MACHPLAN_IN_FRESH;
  if (ahead) flags |= MACHPLAN_IN_AHEAD;
  if (float_switch) flags |= MACHPLAN_IN_FLOAT;
  if (ohmic_sense_in) flags |= MACHPLAN_IN_OHMIC;
  if (breakaway) flags |= MACHPLAN_IN_BREAKAWAY;
  if (stop) flags |= MACHPLAN_IN_STOP;
  if (thc_enable) flags |= MACHPLAN_IN_THC;
  if (torch_enable) flags |= MACHPLAN_IN_TORCH_ENABLE;
  if (op_estop_latched_) flags |= MACHPLAN_IN_OP_ESTOP;
  s = &x->sample[p % MACHPLAN_RING];
  q = s->seq;
  __atomic_store_n(&s->seq, q + 1u, __ATOMIC_RELAXED);
  __atomic_thread_fence(__ATOMIC_RELEASE);
  s->period = p;
  s->flags = flags;
  s->missed = missed_;
  s->comp_state = state_;
  for (i = 0; i < MACHPLAN_HAL_AXES; ++i) {
    s->raw_counts[i] = axis_counts(i);
    s->fb_mm[i] = axis_pos_fb(i);
    s->jog_deflection[i] = jog(i) < -1.0 ? -1.0 : jog(i) > 1.0 ? 1.0 : jog(i);
  }
  s->height_fb_mm = torch_height_fb;
  s->arc_volts = arc_voltage;
  s->feed_override_pct = feed_override;
  s->rapid_override_pct = rapid_override;
  s->recovery_mm = cut_recovery_distance;
  s->paused_speed = paused_motion_speed;
  s->time_ns = rtapi_get_time();
  __atomic_store_n(&s->seq, q + 2u, __ATOMIC_RELEASE);
  x->period_ns = (uint32_t)period;
  x->velocity = velocity;
  x->watchdog = watchdog;
  __atomic_store_n(&x->count, p, __ATOMIC_RELEASE);
}
