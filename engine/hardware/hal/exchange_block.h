/* The memory the `machplan` HAL component (machplan.comp, on the servo thread) and the HAL
 * backend (engine/hardware/hal_backend.cpp, in the machplan program) share: one RTAPI shared
 * memory block under the key MACHPLAN_EXCHANGE_KEY, created by the component when it loads.
 *
 * Plain C, included by both sides; no HAL type appears here. Every field that one side writes
 * while the other reads is accessed with the compiler's __atomic builtins, and the slots of the
 * two rings are guarded by a sequence number (a seqlock): the writer makes `seq` odd, writes
 * the slot, makes it even again; a reader copies the slot and keeps the copy only when `seq`
 * was even and unchanged around it. Neither side ever waits for the other.
 *
 *   commands  written by the program, one slot per servo period it is meant for (slot
 *             period % MACHPLAN_RING); the component takes the slot of the period it is running
 *             when its `period` and `session` match, and otherwise counts the period as missed.
 *             With each command the program also writes the positions it has planned for up to
 *             MACHPLAN_AHEAD_MAX periods after it, flagged MACHPLAN_CMD_AHEAD, into those
 *             periods' slots (each overwritten by the real command when that comes in time, and
 *             cleared when the program has no plan to offer): a late program leaves the axes on
 *             the planned path instead of coasting off it. Such a period still counts as missed.
 *   samples   written by the component every period (slot period % MACHPLAN_RING): the input
 *             pins as they were at the start of that period and what the component did.
 *
 * Sessions: the program opens one by writing a new `session` number and waiting for
 * `session_ack` to show it; the component then clears the watchdog and E-stop latches and
 * waits for the first command. `closed` set to the session number ends it without a watchdog
 * trip. See docs/hal.md for the protocol as a whole. */
#ifndef MACHPLAN_HAL_EXCHANGE_BLOCK_H
#define MACHPLAN_HAL_EXCHANGE_BLOCK_H

#include <stdint.h>

#define MACHPLAN_EXCHANGE_KEY 0x4d504c48 /* "MPLH" */
#define MACHPLAN_EXCHANGE_MAGIC 0x6d706c68u
#define MACHPLAN_EXCHANGE_VERSION 5u /* 2: the probing inputs, ohmic-enable and the operator's other pins; 3: paused-motion-speed, torch-enable, laser-on; 4: positions planned ahead; 5: offset-probe */
#define MACHPLAN_RING 512u /* slots per ring: a power of two; half of it (how far behind the program may read back) more than any watchdog allows (200) */
#define MACHPLAN_AHEAD_MAX 100u /* periods the program may write ahead of a command */
#define MACHPLAN_HAL_AXES 2

/* Command flags */
#define MACHPLAN_CMD_ENABLE 0x1u /* drives enabled */
#define MACHPLAN_CMD_TORCH 0x2u  /* torch on */
#define MACHPLAN_CMD_OHMIC 0x4u  /* ohmic sensing on (ohmic-enable) */
#define MACHPLAN_CMD_LASER 0x8u  /* the laser pointer on (laser-on) */
#define MACHPLAN_CMD_PROBE 0x20u /* the offset probe deployed (offset-probe) */
#define MACHPLAN_CMD_AHEAD 0x10u /* not a command: where the program planned the axes for this period, played when its
                                    command is late (position mode only; the other flags are ignored) */

/* Sample flags */
#define MACHPLAN_IN_ARC_OK 0x1u
#define MACHPLAN_IN_ESTOP 0x2u      /* the E-stop chain is open, or opened during this session */
#define MACHPLAN_IN_WATCHDOG 0x4u   /* the watchdog tripped during this session (latched) */
#define MACHPLAN_IN_FEED_HOLD 0x8u
#define MACHPLAN_IN_CYCLE_START 0x10u
#define MACHPLAN_IN_FRESH 0x20u     /* this period's command arrived in time */
#define MACHPLAN_IN_FLOAT 0x40u     /* the float switch is closed */
#define MACHPLAN_IN_OHMIC 0x80u     /* the ohmic contact is made */
#define MACHPLAN_IN_BREAKAWAY 0x100u /* the torch's breakaway switch is open */
#define MACHPLAN_IN_STOP 0x200u     /* the stop button */
#define MACHPLAN_IN_THC 0x400u      /* torch height control allowed (thc-enable) */
#define MACHPLAN_IN_OP_ESTOP 0x800u /* the operator's E-stop is open, or opened during this session */
#define MACHPLAN_IN_TORCH_ENABLE 0x1000u /* the torch may fire (torch-enable) */
#define MACHPLAN_IN_AHEAD 0x2000u   /* no command in time: the axes took the position planned ahead */

/* Component states (also the `machplan.state` pin) */
#define MACHPLAN_STATE_IDLE 0    /* no session: outputs off, position commands follow pos-fb */
#define MACHPLAN_STATE_ARMED 1   /* a session is open, no command yet: outputs as in idle */
#define MACHPLAN_STATE_RUNNING 2 /* commands arrive: outputs follow them */
#define MACHPLAN_STATE_TRIPPED 3 /* the watchdog tripped: outputs off, latched until reset */

typedef struct {
  uint32_t seq;     /* even: stable; odd: being written */
  uint32_t period;  /* the servo period this command is for */
  uint32_t session;
  uint32_t flags;   /* MACHPLAN_CMD_* */
  double pos_mm[MACHPLAN_HAL_AXES];        /* mm (position mode) */
  double vel_mm_per_s[MACHPLAN_HAL_AXES];  /* at the drive's nominal scaling (velocity mode) */
  double height_mm;                        /* torch height */
} machplan_command;

typedef struct {
  uint32_t seq;
  uint32_t period;  /* the period count when sampled */
  uint32_t flags;   /* MACHPLAN_IN_* */
  uint32_t missed;  /* consecutive periods without a command in time, this one included */
  int32_t raw_counts[MACHPLAN_HAL_AXES];
  int32_t comp_state; /* MACHPLAN_STATE_* */
  double fb_mm[MACHPLAN_HAL_AXES];
  double jog_deflection[MACHPLAN_HAL_AXES];
  double height_fb_mm, arc_volts, feed_override_pct;
  double rapid_override_pct; /* rapid-override as the pin reads, percent */
  double recovery_mm;        /* cut-recovery-distance as the pin reads: a counter, mm */
  double paused_speed;       /* paused-motion-speed as the pin reads: -1 .. 1 */
  int64_t time_ns;  /* rtapi_get_time() when sampled */
} machplan_sample;

typedef struct {
  uint32_t magic, version;       /* written once by the component */
  uint32_t period_ns;            /* the thread's period as the function sees it (0: never ran) */
  uint32_t count;                /* the newest sample's period */
  uint32_t velocity;             /* the component's velocity-mode parameter */
  uint32_t watchdog;             /* the component's watchdog-periods parameter, clamped */
  uint32_t session;              /* written by the program: the session it opens */
  uint32_t session_ack;          /* written by the component: the session it runs */
  uint32_t closed;               /* written by the program: the session it has ended */
  int32_t owner_pid;             /* written by the program: who holds the session */
  machplan_command command[MACHPLAN_RING];
  machplan_sample sample[MACHPLAN_RING];
} machplan_exchange_block;

#endif /* MACHPLAN_HAL_EXCHANGE_BLOCK_H */
