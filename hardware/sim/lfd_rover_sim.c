/*
 * lfd_rover_sim: runs the rover firmware unchanged on simavr (ATmega328P, 16 MHz, headless).
 *
 *   lfd_rover_sim --log motors.csv [--mcu atmega328p] [--freq 16000000] firmware.elf
 *
 * - UART0 is bridged to a fresh pseudo-terminal; the only line on stdout, "PTY <path>", tells
 *   the host where to connect (simavr's own messages go to stderr). The line is 9600 baud 8N1
 *   on the firmware side; the pty itself ignores baud rates.
 * - Simulated time is throttled to the wall clock, so a 300 ms firmware timeout is 300 ms for
 *   the host too. If the host machine stalls, the lost time is dropped rather than caught up,
 *   so the simulation never runs faster than real time.
 * - Every change of the motor outputs is appended to the log as
 *   "t_us,left_pwm,left_dir,right_pwm,right_dir" with the simulated time in microseconds
 *   (monotonic across resets); a line "# reset t_us" marks each board reset. The log is
 *   flushed after every line.
 *   left_pwm/right_pwm: duty 0..255 on D5 (E1, OC0B) / D6 (E2, OC0A): the compare value
 *   while the pin is driven by Timer0 PWM, else 255/0 for a plain high/low output, 0 when the
 *   pin is not an output. left_dir/right_dir: level of D4 (M1) / D7 (M2), 0 unless an output.
 * - SIGUSR1 resets the simulated board (like pressing its reset button). Host bytes are held
 *   back for 2 ms of simulated time after boot and after every reset, so none is lost while the
 *   firmware is still starting; they are delivered, in order, afterwards. SIGTERM or SIGINT
 *   stops the simulation cleanly, as does the exit of the process that started it.
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
} harness_t;

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

/* Waits until the simulation is no longer ahead of the wall clock, waking early for host input. */
static void throttle(harness_t *h, int64_t *wall_origin_ns) {
	int64_t sim_ns = (int64_t)(h->sim_cycles * 1000000000ULL / h->avr->frequency);
	int64_t ahead = sim_ns - (now_ns() - *wall_origin_ns);
	if (ahead < -MAX_LAG_NS) {
		*wall_origin_ns = now_ns() - sim_ns;
		return;
	}
	if (ahead <= 0)
		return;
	struct pollfd pfd = {.fd = h->master_fd, .events = POLLIN};
	struct timespec timeout = {.tv_sec = ahead / 1000000000LL, .tv_nsec = ahead % 1000000000LL};
	ppoll(&pfd, 1, &timeout, NULL);
}

static void usage(const char *argv0) {
	fprintf(stderr, "usage: %s --log PATH [--mcu NAME] [--freq HZ] FIRMWARE.elf\n", argv0);
}

int main(int argc, char **argv) {
	const char *log_path = NULL;
	const char *mcu = "atmega328p";
	uint32_t freq = 16000000;
	static const struct option options[] = {
		{"log", required_argument, NULL, 'l'},
		{"mcu", required_argument, NULL, 'm'},
		{"freq", required_argument, NULL, 'f'},
		{"help", no_argument, NULL, 'h'},
		{NULL, 0, NULL, 0},
	};
	int opt;
	while ((opt = getopt_long(argc, argv, "l:m:f:h", options, NULL)) != -1) {
		switch (opt) {
		case 'l': log_path = optarg; break;
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
	log_motors(&h);
	fprintf(announce, "PTY %s\n", pty_name);
	fclose(announce);

	const avr_cycle_count_t slice = (avr_cycle_count_t)freq / 1000000 * SLICE_US;
	const uint64_t hold_cycles = (uint64_t)freq / 1000000 * INPUT_HOLD_AFTER_RESET_US;
	h.input_hold_until = hold_cycles;
	int64_t wall_origin_ns = now_ns();
	int exit_code = 0;
	unsigned slices = 0;
	while (!stop_requested) {
		/* An orphaned harness would run forever: stop when whoever started it is gone. */
		if (++slices % 100 == 0 && getppid() != parent)
			break;
		if (reset_requested) {
			reset_requested = 0;
			avr_reset(h.avr);
			h.uart_xoff = 0;
			h.to_board.len = 0;
			advance_clock(&h);
			h.input_hold_until = h.sim_cycles + hold_cycles;
			fprintf(h.log, "# reset %llu\n", (unsigned long long)sim_time_us(&h));
			fflush(h.log);
		}
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
