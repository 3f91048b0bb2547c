/*
 * lfd_rover_sim: runs the rover firmware unchanged on simavr (ATmega328P, 16 MHz, headless).
 *
 *   lfd_rover_sim --log motors.csv [--control] [--optiboot] [--mcu atmega328p] [--freq 16000000]
 *                 firmware.elf
 *
 * - UART0 is bridged to a fresh pseudo-terminal; the only line on stdout, "PTY <path>", tells
 *   the host where to connect (simavr's own messages go to stderr). The line is 9600 baud 8N1
 *   on the firmware side; the pty itself ignores baud rates.
 * - Simulated time is paced to the wall clock, so a 300 ms firmware timeout is 300 ms for the
 *   host too: the simulation runs in 200 us slices and sleeps before the next slice until the
 *   wall clock has caught up, whatever the UART is doing (a flood of host bytes included). If the
 *   host machine stalls, the lost time is dropped rather than caught up, so the simulation never
 *   runs faster than real time.
 * - Every change of the motor outputs is appended to the log as
 *   "t_us,left_pwm,left_dir,right_pwm,right_dir" with the simulated time in microseconds
 *   (monotonic across resets); a line "# reset t_us CAUSE" marks each board reset, whatever
 *   caused it: CAUSE is the reset flag the MCU status register (MCUSR) holds after it,
 *   "power-on", "external" (reset pin), "brown-out" or "watchdog" (the AVR hardware watchdog
 *   timed out). The log is flushed after every line.
 * - With --optiboot, every boot (the first one, and after every reset, the watchdog's included)
 *   hands the reset flags over as the Optiboot bootloader does before it starts the sketch:
 *   MCUSR is cleared and its old value is left in register r2. The log names the cause from the
 *   flags before they were moved.
 *   left_pwm/right_pwm: duty 0..255 on D5 (E1, OC0B) / D6 (E2, OC0A): the compare value
 *   while the pin is driven by Timer0 PWM, else 255/0 for a plain high/low output, 0 when the
 *   pin is not an output. left_dir/right_dir: level of D4 (M1) / D7 (M2), 0 unless an output.
 * - SIGUSR1 resets the simulated board through its reset pin (like pressing its reset button).
 *   With --control, stdin takes one command per line (the Python helper uses this):
 *     reset external | reset power-on | reset brown-out
 *                       reset the board with that cause; power-on also scrambles the SRAM
 *                       and registers, as their contents are undefined after power-up;
 *                       "reset CAUSE flags-cleared" leaves MCUSR zero, as a bootloader that
 *                       clears it before starting the firmware and passes nothing on does
 *                       (r2 is zeroed too; logged cause "unknown")
 *     hang              the firmware stops executing instructions, as if stuck in a loop with
 *                       interrupts off, while the timers run on: the watchdog, if enabled,
 *                       resets the board, which then runs normally again ("# hang t_us" is
 *                       logged when it starts)
 *     mark              append "# mark t_us" to the log (the simulated time now)
 *     poke ADDR BYTE..  write up to 16 bytes (hex) to the data space from address ADDR (hex, as
 *                       avr-nm prints it less 0x800000), between two instructions while
 *                       interrupts are enabled, so neither an interrupt handler nor an
 *                       interrupts-off section sees half of it (tests use it to move the
 *                       Arduino millis() clock); "# poke t_us" is logged once written
 *   and the end of stdin stops the harness.
 *   Host bytes are held back for 2 ms of simulated time after boot and after every reset, so
 *   none is lost while the firmware is still starting; they are delivered, in order,
 *   afterwards. SIGTERM or SIGINT stops the simulation cleanly, as does the exit of the process
 *   that started it.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <poll.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_irq.h"
#include "sim_regbit.h"

/* ATmega328P data-space addresses (I/O register + 0x20) of the registers behind the motor pins. */
enum {
	REG_DDRD = 0x2A,
	REG_PORTD = 0x2B,
	REG_TCCR0A = 0x44,
	REG_OCR0A = 0x47,
	REG_OCR0B = 0x48,
};
enum { BIT_LEFT_DIR = 4, BIT_LEFT_PWM = 5, BIT_RIGHT_PWM = 6, BIT_RIGHT_DIR = 7 };
/* TCCR0A compare-output mode bits: COM0A1:0 = bits 7:6 (OC0A, D6), COM0B1:0 = bits 5:4. */
enum { COM0A1 = 7, COM0A0 = 6, COM0B1 = 5, COM0B0 = 4 };

/* Simulated time is run in slices of this length between pty polls and throttle checks. */
#define SLICE_US 200
/* Host bytes are held back this long after a reset, until the firmware has certainly opened its
 * UART (setup() takes ~0.2 ms); earlier bytes would be dropped by the disabled receiver. */
#define INPUT_HOLD_AFTER_RESET_US 2000
/* If the simulation falls further than this behind the wall clock, the debt is forgiven. */
#define MAX_LAG_NS (20 * 1000 * 1000LL)
#define RING_SIZE 4096
#define POKE_MAX 16

typedef struct {
	uint8_t data[RING_SIZE];
	size_t head, len;
} ring_t;

typedef struct {
	int left_pwm, left_dir, right_pwm, right_dir;
} motors_t;

typedef struct {
	avr_t *avr;
	avr_irq_t *uart_in;
	int master_fd;
	int slave_fd;
	int uart_xoff;
	ring_t to_host;  /* bytes the firmware sent, not yet written to the pty */
	ring_t to_board; /* bytes the host sent, not yet accepted by the UART */
	FILE *log;
	motors_t motors;
	uint64_t sim_cycles; /* monotonic across resets */
	uint64_t input_hold_until; /* sim_cycles before which host bytes are not injected */
	avr_cycle_count_t last_cycle;
	avr_io_t reset_watch;  /* a pseudo peripheral whose reset hook sees every board reset */
	int reset_seen;        /* a reset happened and is not logged yet */
	int hung;              /* the "hang" command is in effect */
	void (*normal_run)(avr_t *avr);
	int control;           /* stdin carries commands (--control) */
	int optiboot;          /* hand reset flags over in r2, MCUSR cleared (--optiboot) */
	char control_buf[128];
	size_t control_len;
	uint32_t scramble;     /* xorshift state for the power-on SRAM contents */
	uint64_t hold_cycles;  /* how long host bytes are held back after a reset */
	uint32_t poke_addr;    /* a "poke" waiting for interrupts to be enabled */
	uint8_t poke_data[POKE_MAX];
	size_t poke_len;
} harness_t;

static harness_t *the_harness; /* for simavr callbacks that carry no parameter */

static volatile sig_atomic_t stop_requested = 0;
static volatile sig_atomic_t reset_requested = 0;

static void on_stop_signal(int sig) {
	(void)sig;
	stop_requested = 1;
}

static void on_reset_signal(int sig) {
	(void)sig;
	reset_requested = 1;
}

static size_t ring_push(ring_t *r, const uint8_t *src, size_t n) {
	size_t done = 0;
	while (done < n && r->len < RING_SIZE) {
		r->data[(r->head + r->len) % RING_SIZE] = src[done++];
		r->len++;
	}
	return done;
}

static void ring_drop(ring_t *r, size_t n) {
	r->head = (r->head + n) % RING_SIZE;
	r->len -= n;
}

/* Contiguous readable bytes at the head. */
static size_t ring_peek(const ring_t *r, const uint8_t **out) {
	*out = r->data + r->head;
	size_t contiguous = RING_SIZE - r->head;
	return r->len < contiguous ? r->len : contiguous;
}

static int64_t now_ns(void) {
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static void on_uart_output(struct avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq;
	harness_t *h = param;
	uint8_t byte = (uint8_t)value;
	/* A host that stops reading loses the newest bytes, like a full serial buffer would. */
	ring_push(&h->to_host, &byte, 1);
}

static void on_uart_xon(struct avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq;
	(void)value;
	harness_t *h = param;
	h->uart_xoff = 0;
}

static void on_uart_xoff(struct avr_irq_t *irq, uint32_t value, void *param) {
	(void)irq;
	harness_t *h = param;
	h->uart_xoff = value != 0;
}

static int pwm_duty(const uint8_t *data, int bit, int com1, int com0, uint8_t ocr) {
	if (!(data[REG_DDRD] & (1 << bit)))
		return 0;
	uint8_t tccr = data[REG_TCCR0A];
	if (tccr & (1 << com1))
		return (tccr & (1 << com0)) ? 255 - ocr : ocr; /* inverting vs normal compare output */
	return (data[REG_PORTD] & (1 << bit)) ? 255 : 0;
}

static int pin_level(const uint8_t *data, int bit) {
	return (data[REG_DDRD] & (1 << bit)) && (data[REG_PORTD] & (1 << bit)) ? 1 : 0;
}

static uint64_t sim_time_us(const harness_t *h) {
	return h->sim_cycles * 1000000ULL / h->avr->frequency;
}

static void log_motors(harness_t *h) {
	fprintf(h->log, "%llu,%d,%d,%d,%d\n", (unsigned long long)sim_time_us(h), h->motors.left_pwm,
		h->motors.left_dir, h->motors.right_pwm, h->motors.right_dir);
	fflush(h->log);
}

static void sample_motors(harness_t *h) {
	const uint8_t *d = h->avr->data;
	motors_t m = {
		.left_pwm = pwm_duty(d, BIT_LEFT_PWM, COM0B1, COM0B0, d[REG_OCR0B]),
		.left_dir = pin_level(d, BIT_LEFT_DIR),
		.right_pwm = pwm_duty(d, BIT_RIGHT_PWM, COM0A1, COM0A0, d[REG_OCR0A]),
		.right_dir = pin_level(d, BIT_RIGHT_DIR),
	};
	if (memcmp(&m, &h->motors, sizeof m) != 0) {
		h->motors = m;
		log_motors(h);
	}
}

/* simavr calls every peripheral's reset hook from avr_reset(), whatever started it: the harness,
 * or the watchdog timing out inside avr_run(). Only note it here: the flags in MCUSR are final
 * once avr_reset() has returned. */
static void on_board_reset(avr_io_t *io) {
	(void)io;
	the_harness->reset_seen = 1;
}

static const char *reset_cause(harness_t *h) {
	if (avr_regbit_get(h->avr, h->avr->reset_flags.wdrf))
		return "watchdog";
	if (avr_regbit_get(h->avr, h->avr->reset_flags.borf))
		return "brown-out";
	if (avr_regbit_get(h->avr, h->avr->reset_flags.extrf))
		return "external";
	if (avr_regbit_get(h->avr, h->avr->reset_flags.porf))
		return "power-on";
	return "unknown";
}

/* A firmware stuck with interrupts off: no instruction runs, the cycle timers (the watchdog's
 * among them) do. */
static void hung_run(avr_t *avr) {
	avr_cycle_count_t next = avr_cycle_timer_process(avr);
	avr->cycle += next > 0 ? next : 1;
}

static void advance_clock(harness_t *h) {
	avr_cycle_count_t c = h->avr->cycle;
	/* simavr versions differ on whether a reset rewinds the cycle counter; never go back. */
	if (c >= h->last_cycle)
		h->sim_cycles += c - h->last_cycle;
	h->last_cycle = c;
}

static int open_pty(harness_t *h, char *name, size_t name_len) {
	int fd = posix_openpt(O_RDWR | O_NOCTTY);
	if (fd < 0 || grantpt(fd) < 0 || unlockpt(fd) < 0) {
		perror("lfd_rover_sim: posix_openpt");
		return -1;
	}
	if (ptsname_r(fd, name, name_len) != 0) {
		perror("lfd_rover_sim: ptsname_r");
		return -1;
	}
	/* Holding the slave open keeps the master usable while no host is connected, and raw mode
	 * from the start stops the line discipline echoing firmware output back as input. */
	int slave = open(name, O_RDWR | O_NOCTTY);
	if (slave < 0) {
		perror("lfd_rover_sim: open pty slave");
		return -1;
	}
	struct termios tio;
	tcgetattr(slave, &tio);
	cfmakeraw(&tio);
	cfsetispeed(&tio, B9600);
	cfsetospeed(&tio, B9600);
	tcsetattr(slave, TCSANOW, &tio);
	fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
	h->master_fd = fd;
	h->slave_fd = slave;
	return 0;
}

static void pump_pty(harness_t *h) {
	uint8_t buf[256];
	size_t room = RING_SIZE - h->to_board.len;
	if (room > 0) {
		ssize_t n = read(h->master_fd, buf, room < sizeof buf ? room : sizeof buf);
		if (n > 0)
			ring_push(&h->to_board, buf, (size_t)n);
	}
	/* Hand bytes to the UART only while its receive FIFO has room (XOFF clear). */
	while (h->to_board.len > 0 && !h->uart_xoff && h->sim_cycles >= h->input_hold_until) {
		const uint8_t *p;
		ring_peek(&h->to_board, &p);
		avr_raise_irq(h->uart_in, *p);
		ring_drop(&h->to_board, 1);
	}
	while (h->to_host.len > 0) {
		const uint8_t *p;
		size_t n = ring_peek(&h->to_host, &p);
		ssize_t written = write(h->master_fd, p, n);
		if (written <= 0)
			break;
		ring_drop(&h->to_host, (size_t)written);
	}
}

/* Sleeps until the wall clock has caught up with the simulation. Nothing wakes it early: host
 * bytes wait in the pty (at most one slice, 200 us) and are read before the next slice, so
 * however busy the UART is, simulated time never runs ahead of the wall clock. */
static void throttle(harness_t *h, int64_t *wall_origin_ns) {
	int64_t sim_ns = (int64_t)(h->sim_cycles * 1000000000ULL / h->avr->frequency);
	int64_t ahead = sim_ns - (now_ns() - *wall_origin_ns);
	if (ahead < -MAX_LAG_NS) {
		*wall_origin_ns = now_ns() - sim_ns;
		return;
	}
	if (ahead <= 0)
		return;
	int64_t wake_ns = *wall_origin_ns + sim_ns;
	struct timespec until = {.tv_sec = wake_ns / 1000000000LL, .tv_nsec = wake_ns % 1000000000LL};
	while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, NULL) == EINTR &&
	       !stop_requested && !reset_requested)
		;
}

static uint8_t next_random(harness_t *h) {
	uint32_t x = h->scramble;
	x ^= x << 13;
	x ^= x >> 17;
	x ^= x << 5;
	h->scramble = x;
	return (uint8_t)x;
}

/* With --optiboot: moves the reset flags from MCUSR to r2, as Optiboot does before it jumps to
 * the sketch. Runs before the first instruction after a reset (simavr resets between two
 * instructions, and the harness sees it before it runs the next). */
static void bootloader_handover(harness_t *h) {
	if (!h->optiboot)
		return;
	uint16_t mcusr = h->avr->reset_flags.porf.reg;
	h->avr->data[2] = h->avr->data[mcusr] & 0x0F;
	h->avr->data[mcusr] = 0;
}

/* Logs a reset that has just happened (whoever caused it) and restarts the host input. */
static void after_reset(harness_t *h) {
	h->reset_seen = 0;
	if (h->hung) {
		/* The watchdog's reset restores the run hook it saw when it fired, the hung one. */
		h->hung = 0;
		h->avr->run = h->normal_run;
	}
	h->uart_xoff = 0;
	h->to_board.len = 0;
	advance_clock(h);
	h->input_hold_until = h->sim_cycles + h->hold_cycles;
	fprintf(h->log, "# reset %llu %s\n", (unsigned long long)sim_time_us(h), reset_cause(h));
	fflush(h->log);
	bootloader_handover(h);
}

/* Resets the board from outside: "external" (reset pin), "power-on" or "brown-out"; with
 * flags_cleared, MCUSR stays zero. */
static void reset_board(harness_t *h, const char *cause, int flags_cleared) {
	avr_t *avr = h->avr;
	avr_reset(avr); /* clears every I/O register, MCUSR included */
	if (strcmp(cause, "power-on") == 0) {
		/* Registers and SRAM hold no defined values after power-up; simavr keeps them. */
		for (uint32_t a = 0; a < 32; a++)
			avr->data[a] = next_random(h);
		for (uint32_t a = avr->ioend + 1u; a <= avr->ramend; a++)
			avr->data[a] = next_random(h);
	}
	if (flags_cleared) {
		/* MCUSR stays as avr_reset() left it, zero, and a bootloader that passes nothing on
		 * leaves no flags in r2 either. */
		avr->data[2] = 0;
	} else if (strcmp(cause, "power-on") == 0) {
		avr_regbit_set(avr, avr->reset_flags.porf);
	} else if (strcmp(cause, "brown-out") == 0) {
		avr_regbit_set(avr, avr->reset_flags.borf);
	} else {
		avr_regbit_set(avr, avr->reset_flags.extrf);
	}
	after_reset(h);
}

/* Writes a waiting "poke" once the firmware runs with interrupts enabled (SREG I set): then it
 * is neither inside an interrupt handler nor in a cli() section such as millis()'s read. */
static void apply_poke(harness_t *h) {
	if (h->poke_len == 0 || !h->avr->sreg[S_I])
		return;
	memcpy(h->avr->data + h->poke_addr, h->poke_data, h->poke_len);
	h->poke_len = 0;
	fprintf(h->log, "# poke %llu\n", (unsigned long long)sim_time_us(h));
	fflush(h->log);
}

/* Parses "ADDR BYTE..." (hex) into a waiting poke; 0 if it is malformed or leaves the SRAM. */
static int parse_poke(harness_t *h, const char *args) {
	char *end;
	unsigned long addr = strtoul(args, &end, 16);
	if (end == args)
		return 0;
	uint8_t data[POKE_MAX];
	size_t len = 0;
	for (;;) {
		const char *start = end;
		unsigned long byte = strtoul(start, &end, 16);
		if (end == start)
			break;
		if (byte > 0xFF || len == POKE_MAX)
			return 0;
		data[len++] = (uint8_t)byte;
	}
	if (len == 0 || *end != '\0' || addr <= h->avr->ioend || addr > h->avr->ramend ||
	    len > h->avr->ramend - addr + 1)
		return 0;
	memcpy(h->poke_data, data, len);
	h->poke_addr = (uint32_t)addr;
	h->poke_len = len;
	return 1;
}

static void run_command(harness_t *h, const char *line) {
	static const char *const causes[] = {"external", "power-on", "brown-out"};
	if (strncmp(line, "reset ", 6) == 0) {
		char cause[32] = "";
		char modifier[32] = "";
		int fields = sscanf(line + 6, "%31s %31s", cause, modifier);
		int known = 0;
		for (size_t i = 0; i < sizeof causes / sizeof causes[0]; i++)
			known |= strcmp(cause, causes[i]) == 0;
		int cleared = fields == 2 && strcmp(modifier, "flags-cleared") == 0;
		if (known && (fields == 1 || cleared))
			reset_board(h, cause, cleared);
		else
			fprintf(stderr, "lfd_rover_sim: unknown command %s\n", line);
	} else if (strcmp(line, "hang") == 0) {
		if (!h->hung) {
			h->normal_run = h->avr->run;
			h->avr->run = hung_run;
			h->hung = 1;
			fprintf(h->log, "# hang %llu\n", (unsigned long long)sim_time_us(h));
			fflush(h->log);
		}
	} else if (strncmp(line, "poke ", 5) == 0) {
		if (!parse_poke(h, line + 5))
			fprintf(stderr, "lfd_rover_sim: bad poke %s\n", line);
	} else if (strcmp(line, "mark") == 0) {
		fprintf(h->log, "# mark %llu\n", (unsigned long long)sim_time_us(h));
		fflush(h->log);
	} else {
		fprintf(stderr, "lfd_rover_sim: unknown command %s\n", line);
	}
}

/* Runs the complete command lines waiting on stdin; nonzero once stdin has ended. */
static int read_control(harness_t *h) {
	for (;;) {
		size_t room = sizeof h->control_buf - 1 - h->control_len;
		ssize_t n = read(STDIN_FILENO, h->control_buf + h->control_len, room);
		if (n == 0)
			return 1;
		if (n < 0)
			return errno == EAGAIN || errno == EINTR ? 0 : 1;
		h->control_len += (size_t)n;
		char *start = h->control_buf;
		char *newline;
		while ((newline = memchr(start, '\n', h->control_len - (size_t)(start - h->control_buf)))) {
			*newline = '\0';
			run_command(h, start);
			start = newline + 1;
		}
		h->control_len -= (size_t)(start - h->control_buf);
		memmove(h->control_buf, start, h->control_len);
		if (h->control_len == sizeof h->control_buf - 1)
			h->control_len = 0; /* an over-long line: drop it */
	}
}

static void usage(const char *argv0) {
	fprintf(stderr,
		"usage: %s --log PATH [--control] [--optiboot] [--mcu NAME] [--freq HZ] FIRMWARE.elf\n",
		argv0);
}

int main(int argc, char **argv) {
	const char *log_path = NULL;
	const char *mcu = "atmega328p";
	uint32_t freq = 16000000;
	static const struct option options[] = {
		{"log", required_argument, NULL, 'l'},
		{"control", no_argument, NULL, 'c'},
		{"optiboot", no_argument, NULL, 'o'},
		{"mcu", required_argument, NULL, 'm'},
		{"freq", required_argument, NULL, 'f'},
		{"help", no_argument, NULL, 'h'},
		{NULL, 0, NULL, 0},
	};
	int opt;
	int control = 0;
	int optiboot = 0;
	while ((opt = getopt_long(argc, argv, "l:com:f:h", options, NULL)) != -1) {
		switch (opt) {
		case 'l': log_path = optarg; break;
		case 'c': control = 1; break;
		case 'o': optiboot = 1; break;
		case 'm': mcu = optarg; break;
		case 'f': freq = (uint32_t)strtoul(optarg, NULL, 10); break;
		default: usage(argv[0]); return opt == 'h' ? 0 : 2;
		}
	}
	if (!log_path || optind != argc - 1 || freq == 0) {
		usage(argv[0]);
		return 2;
	}
	const char *elf_path = argv[optind];

	/* simavr prints progress on stdout; keep stdout for the one PTY line the host parses and
	 * send everything else to stderr. */
	FILE *announce = fdopen(dup(STDOUT_FILENO), "w");
	fflush(stdout);
	dup2(STDERR_FILENO, STDOUT_FILENO);
	const pid_t parent = getppid();

	harness_t h;
	memset(&h, 0, sizeof h);
	the_harness = &h;
	h.control = control;
	h.optiboot = optiboot;
	h.scramble = 0x9E3779B9u;
	if (control)
		fcntl(STDIN_FILENO, F_SETFL, fcntl(STDIN_FILENO, F_GETFL) | O_NONBLOCK);
	h.log = fopen(log_path, "w");
	if (!h.log) {
		fprintf(stderr, "lfd_rover_sim: cannot open log %s: %s\n", log_path, strerror(errno));
		return 1;
	}

	elf_firmware_t fw;
	memset(&fw, 0, sizeof fw);
	if (elf_read_firmware(elf_path, &fw) != 0) {
		fprintf(stderr, "lfd_rover_sim: cannot read firmware %s\n", elf_path);
		return 1;
	}
	h.avr = avr_make_mcu_by_name(mcu);
	if (!h.avr) {
		fprintf(stderr, "lfd_rover_sim: unknown MCU %s\n", mcu);
		return 1;
	}
	avr_init(h.avr);
	/* The Arduino ELF carries no simavr MCU section, so the clock is set here. */
	fw.frequency = freq;
	strncpy(fw.mmcu, mcu, sizeof fw.mmcu - 1);
	avr_load_firmware(h.avr, &fw);
	h.avr->frequency = freq;
	h.avr->log = 0;

	/* Route UART0 to the pty only: no console echo, no polling sleeps in the core. */
	uint32_t flags = 0;
	avr_ioctl(h.avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
	flags &= ~(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
	avr_ioctl(h.avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	h.uart_in = avr_io_getirq(h.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_t *uart_out = avr_io_getirq(h.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT);
	avr_irq_t *xon = avr_io_getirq(h.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON);
	avr_irq_t *xoff = avr_io_getirq(h.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF);
	if (!h.uart_in || !uart_out || !xon || !xoff) {
		fprintf(stderr, "lfd_rover_sim: %s has no UART0\n", mcu);
		return 1;
	}
	avr_irq_register_notify(uart_out, on_uart_output, &h);
	h.reset_watch.kind = "lfd_rover_sim reset watch";
	h.reset_watch.reset = on_board_reset;
	avr_register_io(h.avr, &h.reset_watch);
	avr_irq_register_notify(xon, on_uart_xon, &h);
	avr_irq_register_notify(xoff, on_uart_xoff, &h);

	char pty_name[128];
	if (open_pty(&h, pty_name, sizeof pty_name) != 0)
		return 1;

	struct sigaction sa;
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_stop_signal;
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
	sa.sa_handler = on_reset_signal;
	sigaction(SIGUSR1, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);

	fprintf(h.log, "t_us,left_pwm,left_dir,right_pwm,right_dir\n");
	h.last_cycle = h.avr->cycle;
	bootloader_handover(&h); /* the first boot, a power-on, goes through the bootloader too */
	log_motors(&h);
	fprintf(announce, "PTY %s\n", pty_name);
	fclose(announce);

	const avr_cycle_count_t slice = (avr_cycle_count_t)freq / 1000000 * SLICE_US;
	h.hold_cycles = (uint64_t)freq / 1000000 * INPUT_HOLD_AFTER_RESET_US;
	h.input_hold_until = h.hold_cycles;
	int64_t wall_origin_ns = now_ns();
	int exit_code = 0;
	unsigned slices = 0;
	while (!stop_requested) {
		/* An orphaned harness would run forever: stop when whoever started it is gone. */
		if (++slices % 100 == 0 && getppid() != parent)
			break;
		if (reset_requested) {
			reset_requested = 0;
			reset_board(&h, "external", 0);
		}
		if (h.control && read_control(&h) != 0)
			break;
		uint64_t slice_end = h.sim_cycles + slice;
		while (h.sim_cycles < slice_end) {
			int state = avr_run(h.avr);
			if (state == cpu_Done || state == cpu_Crashed) {
				/* avr_run has already torn the core down on cpu_Done: touch nothing in it. */
				fprintf(stderr, "lfd_rover_sim: firmware stopped (state %d)\n", state);
				exit_code = 1;
				goto done;
			}
			advance_clock(&h);
			if (h.reset_seen)
				after_reset(&h);
			apply_poke(&h);
			sample_motors(&h);
		}
		pump_pty(&h);
		throttle(&h, &wall_origin_ns);
	}
done:
	pump_pty(&h);
	fflush(h.log);
	fclose(h.log);
	close(h.slave_fd);
	close(h.master_fd);
	return exit_code;
}
