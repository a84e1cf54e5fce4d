// odolink_robot: a differential-drive robot that odocal can calibrate.
//
// What this sketch does for you: the odolink serial protocol on Serial
// (115200 8N1), the calibration parameters persisted in the EEPROM (a
// power cut while saving keeps the old set), wheel encoders counted by
// interrupts, odometry in float, telemetry while a run lasts.
// What you write: the motion itself, at the places marked
// "YOUR MOTION CODE HERE". As shipped, the sketch drives `straight` runs open
// loop (both motors at one PWM until the odometry says the distance is done)
// and refuses the other procedures.
//
// Wiring (Arduino Uno / Nano, ATmega328P):
//   left encoder  A -> pin 2 (INT0), B -> pin 4
//   right encoder A -> pin 3 (INT1), B -> pin 5
//   left motor  PWM -> pin 9,  direction -> pin 7
//   right motor PWM -> pin 10, direction -> pin 8
// Each rising edge of channel A is one tick (1x decoding), so ticks_per_rev
// is the encoder's lines per wheel revolution (times the gear ratio).
//
// The library: the Arduino library "odolink" (../odolink with the files of
// robot_link/firmware copied into its src/; see README.md).

#include <Arduino.h>
#include <EEPROM.h>

#include <odolink.h>

// ---- Pins --------------------------------------------------------------

const uint8_t kLeftEncA = 2;
const uint8_t kLeftEncB = 4;
const uint8_t kRightEncA = 3;
const uint8_t kRightEncB = 5;
const uint8_t kLeftPwm = 9;
const uint8_t kLeftDir = 7;
const uint8_t kRightPwm = 10;
const uint8_t kRightDir = 8;

// ---- Encoders ------------------------------------------------------------

volatile int32_t left_ticks = 0;
volatile int32_t right_ticks = 0;

// Direction from channel B at A's rising edge. Which sign is "forward"
// depends on the wiring: swap A/B (or the +/-) if a wheel counts backwards.
void left_encoder_isr() { left_ticks += digitalRead(kLeftEncB) ? -1 : 1; }
void right_encoder_isr() { right_ticks += digitalRead(kRightEncB) ? 1 : -1; }

void read_encoders(int32_t* left, int32_t* right) {
  noInterrupts();  // 32-bit counters: the ISRs must not run between the bytes
  *left = left_ticks;
  *right = right_ticks;
  interrupts();
}

// ---- Motors ----------------------------------------------------------------

// pwm -255..255, positive forward.
void set_motors(int left_pwm, int right_pwm) {
  // YOUR MOTION CODE HERE: your driver's interface (this one is a PWM pin and
  // a direction pin per motor, e.g. an L298N or a DRV8833 in phase/enable mode).
  digitalWrite(kLeftDir, left_pwm >= 0 ? HIGH : LOW);
  digitalWrite(kRightDir, right_pwm >= 0 ? HIGH : LOW);
  analogWrite(kLeftPwm, constrain(abs(left_pwm), 0, 255));
  analogWrite(kRightPwm, constrain(abs(right_pwm), 0, 255));
}

// ---- Calibration: where the parameters are used ---------------------------

// The library keeps wheel diameters and the track as binary64 (olf_f64_t: the
// bits, on AVR) so that a pushed set survives bit for bit; the motion code
// works in float, olf_f64_to_float() converts.
float mm_per_tick_left = 0.0f;
float mm_per_tick_right = 0.0f;
float track_mm = 0.0f;

// Called by the library at boot and whenever odocal commits, sets or rolls
// back a set: from here on, odometry uses the new calibration.
void on_params_applied(void*, const olf_params_t* p) {
  const float ticks = (float)p->ticks_per_rev;
  mm_per_tick_left = PI * olf_f64_to_float(p->left_wheel_diameter_mm) / ticks;
  mm_per_tick_right = PI * olf_f64_to_float(p->right_wheel_diameter_mm) / ticks;
  track_mm = olf_f64_to_float(p->track_mm);
}

// ---- Odometry ----------------------------------------------------------------

struct Odometry {
  int32_t start_left, start_right;  // encoder counts at run start
  int32_t last_left, last_right;
  float x_mm, y_mm, heading_rad;    // in the run's start frame (x forward, y left)
};
Odometry odo;

void odometry_reset() {
  read_encoders(&odo.start_left, &odo.start_right);
  odo.last_left = odo.start_left;
  odo.last_right = odo.start_right;
  odo.x_mm = odo.y_mm = odo.heading_rad = 0.0f;
}

void odometry_update() {
  int32_t l, r;
  read_encoders(&l, &r);
  const float dl = (float)(l - odo.last_left) * mm_per_tick_left;
  const float dr = (float)(r - odo.last_right) * mm_per_tick_right;
  odo.last_left = l;
  odo.last_right = r;
  const float ds = 0.5f * (dl + dr);
  const float dth = (dr - dl) / track_mm;
  const float mid = odo.heading_rad + 0.5f * dth;  // midpoint rule
  odo.x_mm += ds * cosf(mid);
  odo.y_mm += ds * sinf(mid);
  odo.heading_rad += dth;
}

void odometry_sample(olf_telemetry_t* t) {
  t->t_ms = millis();
  t->left_ticks = odo.last_left - odo.start_left;
  t->right_ticks = odo.last_right - odo.start_right;
  t->x_mm = odo.x_mm;  // poses are the target's double (a float on AVR)
  t->y_mm = odo.y_mm;
  t->heading_rad = odo.heading_rad;
}

// ---- Runs ---------------------------------------------------------------------

olf_ctx_t link;  // ~1 KiB of the Uno's 2 KiB: keep it a global

struct Run {
  bool active;
  bool stop_requested;
  float distance_mm;      // straight: signed target
  uint32_t last_progress_ms;
  int32_t last_progress_ticks;
};
Run run;

const int kStraightPwm = 120;
const uint32_t kStallMs = 2000;  // no encoder movement this long: fail the run

// The library validated the command; return 0 to refuse it (odocal reports
// "rejected"), 1 once the robot is moving.
int on_start_run(void*, const olf_run_cmd_t* cmd) {
  if (run.active) return 0;
  switch (cmd->procedure) {
    case OLF_PROC_STRAIGHT:
      run.distance_mm = (float)cmd->amount_mm;
      odometry_reset();
      set_motors(run.distance_mm > 0 ? kStraightPwm : -kStraightPwm,
                 run.distance_mm > 0 ? kStraightPwm : -kStraightPwm);
      break;
    // YOUR MOTION CODE HERE: OLF_PROC_UMBMARK (a square of cmd->amount_mm,
    // cmd->direction), OLF_PROC_SPIN (cmd->count turns on the spot),
    // OLF_PROC_OUT_AND_BACK (cmd->amount_mm out and back, cmd->count times).
    // cmd->speed_mm_s and cmd->turn_rate_ddeg_s are the host's speeds (0: yours).
    default:
      return 0;
  }
  run.active = true;
  run.stop_requested = false;
  run.last_progress_ms = millis();
  run.last_progress_ticks = 0;
  return 1;
}

// Immediate stop requested by the host: brake now, report in loop().
void on_stop(void*) {
  set_motors(0, 0);  // YOUR MOTION CODE HERE: brake the way your drive brakes
  run.stop_requested = true;
}

void end_run(uint8_t status) {
  olf_telemetry_t end;
  set_motors(0, 0);
  run.active = false;
  odometry_update();
  odometry_sample(&end);
  olf_run_complete(&link, status, &end);
}

void run_update() {
  olf_telemetry_t t;
  odometry_update();
  odometry_sample(&t);
  olf_emit_telemetry(&link, &t);  // the library keeps to the host's rate

  if (run.stop_requested) {
    end_run(OLF_RUN_STOPPED);
    return;
  }
  const int32_t moved = abs(t.left_ticks) + abs(t.right_ticks);
  if (moved != run.last_progress_ticks) {
    run.last_progress_ticks = moved;
    run.last_progress_ms = t.t_ms;
  } else if (t.t_ms - run.last_progress_ms > kStallMs) {
    end_run(OLF_RUN_FAILED);  // motors on, wheels still: stalled or not wired
    return;
  }
  // YOUR MOTION CODE HERE: the run's control loop and its end condition.
  if (fabsf(odo.x_mm) >= fabsf(run.distance_mm)) end_run(OLF_RUN_COMPLETED);
}

// ---- Storage: the library's two slots at EEPROM addresses 0..255 -----------------

int storage_read(void*, uint32_t offset, uint8_t* data, uint32_t len) {
  if (offset + len > OLF_STORAGE_SIZE || offset + len > EEPROM.length()) return 0;
  for (uint32_t i = 0; i < len; ++i) data[i] = EEPROM.read((int)(offset + i));
  return 1;
}

// Byte by byte (EEPROM.update skips unchanged bytes and saves wear), each
// read back. A reset half-way leaves the other slot intact: the library's
// slot + CRC scheme turns that into "old set", never a mix.
int storage_write(void*, uint32_t offset, const uint8_t* data, uint32_t len) {
  if (offset + len > OLF_STORAGE_SIZE || offset + len > EEPROM.length()) return 0;
  for (uint32_t i = 0; i < len; ++i) {
    EEPROM.update((int)(offset + i), data[i]);
    if (EEPROM.read((int)(offset + i)) != data[i]) return 0;
  }
  return 1;
}

// ---- Serial ---------------------------------------------------------------------

void serial_write(void*, const uint8_t* data, size_t len) { Serial.write(data, len); }

// ---- Arduino -----------------------------------------------------------------

void setup() {
  pinMode(kLeftEncA, INPUT_PULLUP);
  pinMode(kLeftEncB, INPUT_PULLUP);
  pinMode(kRightEncA, INPUT_PULLUP);
  pinMode(kRightEncB, INPUT_PULLUP);
  pinMode(kLeftDir, OUTPUT);
  pinMode(kRightDir, OUTPUT);
  set_motors(0, 0);
  attachInterrupt(digitalPinToInterrupt(kLeftEncA), left_encoder_isr, RISING);
  attachInterrupt(digitalPinToInterrupt(kRightEncA), right_encoder_isr, RISING);

  Serial.begin(115200);

  olf_config_t config;
  memset(&config, 0, sizeof config);
  config.robot_name = "odolink-arduino";  // YOUR ROBOT'S NAME (up to 32 bytes)
  // YOUR ROBOT'S NOMINAL GEOMETRY: used until odocal commits a calibration.
  config.defaults.left_wheel_diameter_mm = olf_f64_from_float(72.0f);
  config.defaults.right_wheel_diameter_mm = olf_f64_from_float(72.0f);
  config.defaults.track_mm = olf_f64_from_float(270.0f);
  config.defaults.ticks_per_rev = 4096;
  config.storage.read = storage_read;
  config.storage.write = storage_write;
  config.callbacks.write = serial_write;
  config.callbacks.start_run = on_start_run;
  config.callbacks.stop = on_stop;
  config.callbacks.params_applied = on_params_applied;
  olf_init(&link, &config);  // loads the saved set, calls on_params_applied
}

void loop() {
  while (Serial.available() > 0) olf_feed(&link, (uint8_t)Serial.read());
  if (run.active) run_update();
}
