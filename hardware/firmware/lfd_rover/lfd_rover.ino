// lfd_rover: drive firmware for the tracked rover (DFRobot Romeo, ATmega328P at 16 MHz).
//
// Speaks the line-framed wire protocol of lfd_track/hardware/wire.py:
//
//   host -> board  $<type>,<seq>[,<arg>]*<CRC>\n
//     D,<seq>,F|L|R|S  drive forward / spin left / spin right / stop (renews the motor lease);
//                      F, L and R are refused with BOOT until the host has answered this boot
//     K,<seq>,<boot>   hello: the host has seen the boot frame with this boot count; drive
//                      frames are obeyed from now on (a count of another boot is refused, BOOT)
//     H,<seq>          ping (never changes the motors, does not renew the lease)
//     E,<seq>          emergency stop: motors off, latched until C
//     C,<seq>          clear the e-stop; motors stay off until the next drive frame
//     T,<seq>,<ms>     set the lease (software watchdog) period, 50..2000 ms, for the drive
//                      frames that follow (the motion in progress keeps the lease it began with)
//     V,<seq>          version query: acked with three more fields: version, reset cause, boot
//   board -> host
//     $A,<seq>,<state>,<flags>*CRC   ack; state = F/L/R/S (drive now applied) or X (e-stopped)
//     $A,<seq>,<state>,<flags>,<version>,<cause>,<boot>*CRC   the ack to V
//     $N,<seq>,<reason>*CRC          reject; reason = CRC FRAME ARG ESTOP TYPE LONG BOOT
//     $B,0,<version>,<cause>,<flags>,<boot>*CRC   sent once after every reset
//     $W,0,S*CRC                     the lease ran out and the motors were stopped
//
// Boot count: 0..65535, one more at every boot, kept in RAM that resets do not clear (after a
// power-up it starts from whatever the RAM held). A hello must name the current one, so a
// hello or drive written for an earlier boot cannot move this one.
//
// Reset cause, from the MCU status register (MCUSR) at boot, or, when a bootloader cleared it,
// from register r2, where Optiboot hands the flags over: PWR power-on, EXT reset pin, BOD
// brown-out, WDT hardware watchdog, ? none recorded (cleared and not handed over).
//
// CRC is CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over the bytes between '$' and '*',
// written as 4 upper-case hex digits; lower-case digits are accepted on input.
//
// Ack flags, a decimal bitfield:
//   bit 0 (1)  e-stop latched
//   bit 1 (2)  the lease ran out and stopped the motors since the last accepted drive frame
//   bit 2 (4)  replies were dropped since the last ack (sent while the transmit buffer was full)
//
// NAK seq: the frame's own seq when its second field is a valid seq (0..65535), else 0. For CRC
// failures this seq is only a hint, since the bytes it was read from failed the check.
//
// Framing: bytes outside a frame are ignored; '$' always starts a new frame (resynchronises);
// a frame in progress is dropped when no byte of it came for 50 ms (a newline arriving later
// cannot complete it);
// a line longer than 31 bytes ('$' up to, not including, the newline; trailing '\r's are
// stripped first, within the buffer's one spare byte) is rejected as LONG once its newline
// arrives. The receive buffer is a
// fixed 33 bytes.
//
// Load: each pass of loop() kicks the hardware watchdog, checks the lease, and reads at most
// one line's worth of bytes, handling at most one complete line. A reply is only queued when it
// fits the transmit buffer at once; otherwise it is dropped (the frame itself still takes
// effect, and the next ack sets flag 4), so a pass never waits on the 9600 baud link and no
// flood of any input can starve the watchdog or delay the lease.
//
// Safety: a drive frame is a lease. Motors stop when no accepted drive frame arrived within the
// lease period (default 300 ms); they are off at reset until the first drive frame accepted
// after the host's hello for this boot, so a host still re-sending the drive it sent before
// the reset cannot restart them; a ping never starts motion; drive frames (stop included) are
// refused with ESTOP while the e-stop is latched, and clearing it leaves the motors off. The AVR
// hardware watchdog (250 ms) resets the board if the main loop ever hangs. The e-stop latch is
// kept in RAM the C runtime does not clear (.noinit, value and complement): it survives every
// reset that keeps the RAM (a power-up leaves garbage, read as clear), and a watchdog or
// brown-out reset latches it even if it was clear (the board stopped for a fault; the host must
// look before it drives again). None of this replaces the physical motor-power switch.

#include <avr/wdt.h>
#include <util/crc16.h>

static const char FIRMWARE_VERSION[] = "1.2";
static const unsigned long SERIAL_BAUD = 9600;  // HC-05/06 factory default

// DFRobot Romeo motor driver pins.
static const uint8_t PIN_LEFT_PWM = 5;    // E1: left tread speed (Timer0 OC0B)
static const uint8_t PIN_LEFT_DIR = 4;    // M1: left tread direction
static const uint8_t PIN_RIGHT_PWM = 6;   // E2: right tread speed (Timer0 OC0A)
static const uint8_t PIN_RIGHT_DIR = 7;   // M2: right tread direction

// Direction level that drives a tread forward. LOW matches DFRobot's own Romeo example
// ("advance" writes M1/M2 LOW); if a tread runs backward on your chassis, swap its motor leads.
static const uint8_t DIR_FORWARD = LOW;
static const uint8_t DIR_BACKWARD = HIGH;

// Fixed PWM duty for every drive command (0..255, about 78 %): the paper's rover has discrete
// commands only, and a fixed duty keeps the demonstrations and the learned controller alike.
static const uint8_t DRIVE_DUTY = 200;

static const uint16_t LEASE_DEFAULT_MS = 300;
static const uint16_t LEASE_MIN_MS = 50;
static const uint16_t LEASE_MAX_MS = 2000;
// A frame in progress whose next byte has not come for this long is dropped.
static const uint16_t RX_GAP_MS = 50;

static const uint8_t MAX_LINE_BYTES = 31;
// One extra byte lets a trailing '\r' in, which is stripped before the length check.
static const uint8_t RX_CAPACITY = MAX_LINE_BYTES + 1;

static const uint8_t FLAG_ESTOP = 1;
static const uint8_t FLAG_LEASE_EXPIRED = 2;
static const uint8_t FLAG_REPLIES_DROPPED = 4;

static const char STATE_ESTOP = 'X';

// Receive state: one frame in progress at most.
static char rx_buf[RX_CAPACITY + 1];
static uint8_t rx_len = 0;
static bool rx_in_frame = false;
static bool rx_overflow = false;
static unsigned long rx_last_byte_ms = 0;

// Drive state.
static char drive_state = 'S';
static bool estop_latched = false;
static bool lease_expired = false;
static uint16_t lease_ms = LEASE_DEFAULT_MS;    // for the next accepted drive frame
static uint16_t drive_lease_ms = LEASE_DEFAULT_MS;  // of the motion in progress
static bool boot_answered = false;  // the host's hello named this boot; cleared by every reset
static unsigned long last_drive_ms = 0;
static uint8_t left_dir_now = DIR_FORWARD;
static uint8_t right_dir_now = DIR_FORWARD;
static bool replies_dropped = false;
static const char *reset_cause = "?";

// The reset flags of this boot. Written in .init3, before the C runtime clears .bss (.init4), so
// it lives in .noinit, as does r2 as it was at reset (.init0, before anything can change it).
static uint8_t reset_flags __attribute__((section(".noinit")));
static uint8_t r2_at_reset __attribute__((section(".noinit")));

// The e-stop latch as last set and the boot count, in RAM that no reset clears and the C runtime
// leaves alone. Each counts only while it matches its complement (and the latch its magic), which
// random power-up RAM does for the latch once in 2^32.
struct PersistentRecord {
  uint16_t magic;
  uint8_t latched;
  uint8_t latched_inverse;
  uint16_t boot;
  uint16_t boot_inverse;
};
static const uint16_t LATCH_MAGIC = 0x4C46;  // "LF"
static PersistentRecord persistent __attribute__((section(".noinit")));
static uint16_t boot_count = 0;

// Optiboot clears MCUSR before it starts the sketch and leaves the old value in r2. Nothing runs
// before .init0 but the bootloader, so r2 is saved here, with one store (r1 is not zero yet, so
// no compiled C may run).
void save_r2(void) __attribute__((naked, used, section(".init0")));
void save_r2(void) { asm volatile("sts %0, r2" : "=m"(r2_at_reset)); }

// The watchdog stays enabled across a watchdog reset (at the shortest timeout, 16 ms), so it
// must be turned off before the C runtime and Arduino init() run, or the board would reset
// forever; and WDE cannot be cleared while WDRF is set, so MCUSR is saved and cleared first
// (the avr-libc <avr/wdt.h> recipe). setup() re-arms the watchdog.
void save_reset_flags_and_disable_watchdog(void) __attribute__((naked, used, section(".init3")));
// MCUSR holds the flags unless a bootloader cleared it; then they are in r2 if it handed them
// over (Optiboot), else none are known. Without a bootloader MCUSR always has one set.
void save_reset_flags_and_disable_watchdog(void) {
  reset_flags = MCUSR;
  MCUSR = 0;
  wdt_disable();
  if (reset_flags == 0) reset_flags = r2_at_reset & 0x0F;  // PORF, EXTRF, BORF, WDRF
}

static void remember_latch(bool latched) {
  persistent.magic = LATCH_MAGIC;
  persistent.latched = latched ? 1 : 0;
  persistent.latched_inverse = ~persistent.latched;
}

// True if a valid record says latched (a record left by an earlier run, not power-up noise).
static bool remembered_latch() {
  return persistent.magic == LATCH_MAGIC && persistent.latched == 1 &&
         persistent.latched_inverse == (uint8_t)~1;
}

// One more boot: from the record if it is valid, else from whatever the RAM held (a power-up).
static void count_boot() {
  boot_count = persistent.boot + 1;
  persistent.boot = boot_count;
  persistent.boot_inverse = ~boot_count;
}

// Decides the latch at boot: a watchdog or brown-out reset latches; otherwise the record
// decides, which after a power-up is garbage and reads as clear.
static bool latch_after_reset() {
  if (reset_flags & _BV(PORF)) {
    reset_cause = "PWR";
  } else if (reset_flags & _BV(WDRF)) {
    reset_cause = "WDT";
  } else if (reset_flags & _BV(BORF)) {
    reset_cause = "BOD";
  } else {
    reset_cause = (reset_flags & _BV(EXTRF)) ? "EXT" : "?";
  }
  return (reset_flags & (_BV(WDRF) | _BV(BORF))) || remembered_latch();
}

static void set_estop(bool latched) {
  estop_latched = latched;
  remember_latch(latched);
}

static void set_motors(char command) {
  uint8_t left_duty = DRIVE_DUTY;
  uint8_t right_duty = DRIVE_DUTY;
  uint8_t left_dir = DIR_FORWARD;
  uint8_t right_dir = DIR_FORWARD;
  switch (command) {
    case 'F':
      break;
    case 'L':  // spin left on the spot: left tread back, right tread forward
      left_dir = DIR_BACKWARD;
      break;
    case 'R':
      right_dir = DIR_BACKWARD;
      break;
    default:  // 'S' and anything unexpected: both off
      left_duty = 0;
      right_duty = 0;
      break;
  }
  // A tread whose direction changes is switched off first, so it never reverses at full duty
  // for the instant between the two writes. Unchanged values are rewritten as-is (a renewed
  // lease must not glitch the outputs).
  if (left_dir != left_dir_now) analogWrite(PIN_LEFT_PWM, 0);
  if (right_dir != right_dir_now) analogWrite(PIN_RIGHT_PWM, 0);
  digitalWrite(PIN_LEFT_DIR, left_dir);
  digitalWrite(PIN_RIGHT_DIR, right_dir);
  left_dir_now = left_dir;
  right_dir_now = right_dir;
  analogWrite(PIN_LEFT_PWM, left_duty);
  analogWrite(PIN_RIGHT_PWM, right_duty);
}

static uint16_t crc16_update(uint16_t crc, const char *text, uint8_t len) {
  for (uint8_t i = 0; i < len; i++) {
    crc = _crc_xmodem_update(crc, (uint8_t)text[i]);
  }
  return crc;
}

static void write_hex4(uint16_t value) {
  static const char digits[] = "0123456789ABCDEF";
  for (int8_t shift = 12; shift >= 0; shift -= 4) {
    Serial.write(digits[(value >> shift) & 0xF]);
  }
}

// Sends "$<body>*<CRC>\n" if it fits the transmit buffer now, else drops it (and says so in the
// next ack's flags): the caller never waits for the link.
static void send_frame(const char *body) {
  uint8_t len = strlen(body);
  if (Serial.availableForWrite() < len + 7) {
    replies_dropped = true;
    return;
  }
  Serial.write('$');
  Serial.write((const uint8_t *)body, len);
  Serial.write('*');
  write_hex4(crc16_update(0xFFFF, body, len));
  Serial.write('\n');
}

static char current_state() { return estop_latched ? STATE_ESTOP : drive_state; }

static uint8_t current_flags() {
  return (estop_latched ? FLAG_ESTOP : 0) | (lease_expired ? FLAG_LEASE_EXPIRED : 0) |
         (replies_dropped ? FLAG_REPLIES_DROPPED : 0);
}

static void send_ack(uint16_t seq) {
  char body[24];
  uint8_t flags = current_flags();
  replies_dropped = false;  // reported now (or this ack is dropped too and sets it again)
  snprintf(body, sizeof body, "A,%u,%c,%u", seq, current_state(), flags);
  send_frame(body);
}

static void send_version(uint16_t seq) {
  char body[32];
  uint8_t flags = current_flags();
  replies_dropped = false;
  snprintf(body, sizeof body, "A,%u,%c,%u,%s,%s,%u", seq, current_state(), flags,
           FIRMWARE_VERSION, reset_cause, boot_count);
  send_frame(body);
}

static void send_nak(uint16_t seq, const char *reason) {
  char body[24];
  snprintf(body, sizeof body, "N,%u,%s", seq, reason);
  send_frame(body);
}

static int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

static bool is_letter(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }

// Parses a decimal field of 1..max_digits digits; false if it is anything else.
static bool parse_decimal(const char *text, uint8_t len, uint8_t max_digits, uint32_t *out) {
  if (len == 0 || len > max_digits) return false;
  uint32_t value = 0;
  for (uint8_t i = 0; i < len; i++) {
    if (text[i] < '0' || text[i] > '9') return false;
    value = value * 10 + (uint8_t)(text[i] - '0');
  }
  *out = value;
  return true;
}

// Best-effort seq of a line for a NAK: the second comma-separated field of the body, or 0.
static uint16_t guess_seq(const char *body, uint8_t len) {
  uint8_t start = 0;
  while (start < len && body[start] != ',') start++;
  if (start >= len) return 0;
  start++;
  uint8_t end = start;
  while (end < len && body[end] != ',' && body[end] != '*') end++;
  uint32_t seq;
  if (parse_decimal(body + start, end - start, 5, &seq) && seq <= 0xFFFF) return (uint16_t)seq;
  return 0;
}

static void apply_drive(uint16_t seq, char command) {
  if (estop_latched) {
    send_nak(seq, "ESTOP");
    return;
  }
  if (command != 'S' && !boot_answered) {
    send_nak(seq, "BOOT");
    return;
  }
  drive_state = command;
  last_drive_ms = millis();
  drive_lease_ms = lease_ms;
  lease_expired = false;
  set_motors(command);
  send_ack(seq);
}

// Handles one complete line held in rx_buf (starting with '$', newline removed).
static void handle_line() {
  if (rx_overflow) {
    send_nak(guess_seq(rx_buf + 1, rx_len - 1), "LONG");
    return;
  }
  uint8_t len = rx_len;
  while (len > 1 && rx_buf[len - 1] == '\r') len--;  // as the host codec does
  const char *body = rx_buf + 1;
  uint8_t body_span = len - 1;  // bytes after '$'
  if (len > MAX_LINE_BYTES) {
    send_nak(guess_seq(body, body_span), "LONG");
    return;
  }

  // Exactly one '*', followed by exactly 4 hex digits.
  uint8_t star = 0;
  uint8_t stars = 0;
  for (uint8_t i = 0; i < body_span; i++) {
    if (body[i] == '*') {
      star = i;
      stars++;
    }
  }
  uint16_t seq_hint = guess_seq(body, body_span);
  if (stars != 1 || body_span - star - 1 != 4) {
    send_nak(seq_hint, "FRAME");
    return;
  }
  uint16_t received_crc = 0;
  for (uint8_t i = star + 1; i < body_span; i++) {
    int digit = hex_value(body[i]);
    if (digit < 0) {
      send_nak(seq_hint, "FRAME");
      return;
    }
    received_crc = (received_crc << 4) | (uint8_t)digit;
  }
  if (crc16_update(0xFFFF, body, star) != received_crc) {
    send_nak(seq_hint, "CRC");
    return;
  }

  // Split the checked body into fields: type, seq, args.
  const uint8_t MAX_FIELDS = 4;
  const char *field[MAX_FIELDS];
  uint8_t field_len[MAX_FIELDS];
  uint8_t fields = 0;
  uint8_t start = 0;
  for (uint8_t i = 0; i <= star; i++) {
    if ((uint8_t)body[i] >= 0x80) {  // the wire format is ASCII only
      send_nak(seq_hint, "FRAME");
      return;
    }
    if (i == star || body[i] == ',') {
      if (fields < MAX_FIELDS) {
        field[fields] = body + start;
        field_len[fields] = i - start;
      }
      fields++;
      start = i + 1;
    }
  }
  uint32_t seq32;
  if (fields < 2 || field_len[0] != 1 || !is_letter(field[0][0]) ||
      !parse_decimal(field[1], field_len[1], 5, &seq32) || seq32 > 0xFFFF) {
    send_nak(seq_hint, "FRAME");
    return;
  }
  uint16_t seq = (uint16_t)seq32;
  uint8_t args = fields - 2;
  char type = field[0][0];

  switch (type) {
    case 'D': {
      char command = args == 1 && field_len[2] == 1 ? field[2][0] : 0;
      if (command != 'F' && command != 'L' && command != 'R' && command != 'S') {
        send_nak(seq, "ARG");
        return;
      }
      apply_drive(seq, command);
      return;
    }
    case 'H':
      if (args != 0) {
        send_nak(seq, "ARG");
        return;
      }
      send_ack(seq);
      return;
    case 'E':
      if (args != 0) {
        send_nak(seq, "ARG");
        return;
      }
      set_estop(true);
      drive_state = 'S';
      set_motors('S');
      send_ack(seq);
      return;
    case 'C':
      if (args != 0) {
        send_nak(seq, "ARG");
        return;
      }
      set_estop(false);  // motors were stopped when it latched and stay stopped
      send_ack(seq);
      return;
    case 'T': {
      uint32_t period;
      if (args != 1 || !parse_decimal(field[2], field_len[2], 4, &period) ||
          period < LEASE_MIN_MS || period > LEASE_MAX_MS) {
        send_nak(seq, "ARG");
        return;
      }
      lease_ms = (uint16_t)period;
      send_ack(seq);
      return;
    }
    case 'K': {
      uint32_t boot;
      if (args != 1 || !parse_decimal(field[2], field_len[2], 5, &boot)) {
        send_nak(seq, "ARG");
        return;
      }
      if (boot != boot_count) {
        send_nak(seq, "BOOT");
        return;
      }
      boot_answered = true;
      send_ack(seq);
      return;
    }
    case 'V':
      if (args != 0) {
        send_nak(seq, "ARG");
        return;
      }
      send_version(seq);
      return;
    default:
      send_nak(seq, "TYPE");
      return;
  }
}

// Takes one received byte; true when it completed (and handled) a line.
static bool receive_byte(char c) {
  if (c == '$') {  // always resynchronise on '$'
    rx_buf[0] = c;
    rx_len = 1;
    rx_in_frame = true;
    rx_overflow = false;
  } else if (!rx_in_frame) {
    // noise between frames is ignored
  } else if (c == '\n') {
    rx_buf[rx_len] = '\0';
    handle_line();
    rx_len = 0;
    rx_in_frame = false;
    rx_overflow = false;
    return true;
  } else if (rx_overflow) {
    // drop the rest of an over-long line
  } else if (rx_len >= RX_CAPACITY) {
    rx_overflow = true;
  } else {
    rx_buf[rx_len++] = c;
  }
  return false;
}

static void check_lease() {
  if (drive_state == 'S') return;
  if (millis() - last_drive_ms >= drive_lease_ms) {
    drive_state = 'S';
    lease_expired = true;
    set_motors('S');
    send_frame("W,0,S");
  }
}

void setup() {
  // Motors off before anything else, including before the serial link is up.
  pinMode(PIN_LEFT_DIR, OUTPUT);
  pinMode(PIN_RIGHT_DIR, OUTPUT);
  pinMode(PIN_LEFT_PWM, OUTPUT);
  pinMode(PIN_RIGHT_PWM, OUTPUT);
  set_motors('S');
  set_estop(latch_after_reset());
  count_boot();
  Serial.begin(SERIAL_BAUD);
  wdt_enable(WDTO_250MS);
  char body[28];
  snprintf(body, sizeof body, "B,0,%s,%s,%u,%u", FIRMWARE_VERSION, reset_cause, current_flags(),
           boot_count);
  send_frame(body);
}

// Bytes read per pass at most: one maximal line with its newline. At 16 MHz a pass takes well
// under a millisecond, so the receiver (64-byte buffer, ~1 byte per ms at 9600 baud) keeps up.
static const uint8_t READ_BUDGET = RX_CAPACITY + 1;

void loop() {
  wdt_reset();
  check_lease();
  if (rx_in_frame && millis() - rx_last_byte_ms >= RX_GAP_MS) {
    rx_in_frame = false;  // its newline never came: drop it, whatever arrives later
    rx_len = 0;
    rx_overflow = false;
  }
  for (uint8_t budget = READ_BUDGET; budget > 0 && Serial.available() > 0; budget--) {
    rx_last_byte_ms = millis();
    if (receive_byte((char)Serial.read())) break;  // at most one line handled per pass
  }
}
