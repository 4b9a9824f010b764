/* libmodbus (Debian's libmodbus 3.1) as a master of `lec sim`.
 *
 *   libmodbus_peer PORT
 *
 * Runs the manual's operation examples 1-4 with modbus_write_bit /
 * modbus_write_bits / modbus_write_registers / modbus_read_input_bits /
 * modbus_read_registers, checks the final positions, the exception codes
 * (errno EMBXILFUN / EMBXILADD / EMBXILVAL), and an FC08 echo.
 *
 * libmodbus quirk: it has no FC08 request of its own and its confirmation
 * parser cannot size an FC08 reply, so the echo is sent with
 * modbus_send_raw_request() and its 8-byte reply read straight from the
 * descriptor (modbus_get_socket) with a bounded poll().
 *
 * Prints one line per check and "N passed, N failed"; exit status 1 on any
 * failure. Every wait is bounded by a deadline. */

#include <errno.h>
#include <modbus.h>
#include <poll.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum { SVRE = 9, SETON = 10, INP = 11, BUSY = 8 };

static int passed, failed;

static void check(int ok, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  fputs(ok ? "ok   " : "FAIL ", stdout);
  vprintf(fmt, ap);
  va_end(ap);
  fputc('\n', stdout);
  fflush(stdout);
  if (ok)
    ++passed;
  else
    ++failed;
}

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

static int step_address(int n) {
  return 0x0400 + 0x10 * n;
}

/* A positioning record as the manual's example 4 (ABS, 500 mm/s, accel and
 * decel 5000, pushing speed 20, moving force 100, in position 1.00 mm). */
static void record(uint16_t regs[16], int32_t position_001mm) {
  const uint16_t r[16] = {1,
                          500,
                          (uint16_t)((uint32_t)position_001mm >> 16),
                          (uint16_t)(position_001mm & 0xFFFF),
                          5000,
                          5000,
                          0,
                          0,
                          20,
                          100,
                          0,
                          0,
                          0,
                          0,
                          0,
                          100};
  memcpy(regs, r, sizeof r);
}

/* X40-X4F as 16 bits; -1 on error. */
static int read_flags(modbus_t* ctx, uint8_t bits[16]) {
  return modbus_read_input_bits(ctx, 0x40, 16, bits) == 16 ? 0 : -1;
}

/* Waits until bits[a] == va and bits[b] == vb (b < 0: only a). */
static int wait_flags(modbus_t* ctx, int a, int va, int b, int vb, uint8_t bits[16]) {
  const double deadline = now_s() + 10.0;
  while (now_s() < deadline) {
    if (read_flags(ctx, bits) != 0) return -1;
    if (bits[a] == va && (b < 0 || bits[b] == vb)) return 0;
  }
  return -1;
}

static int32_t read_position(modbus_t* ctx, int* ok) {
  uint16_t r[2] = {0, 0};
  *ok = modbus_read_registers(ctx, 0x9000, 2, r) == 2;
  return (int32_t)(((uint32_t)r[0] << 16) | r[1]);
}

static int only(const uint8_t bits[16], int a, int b, int c) {
  for (int i = 0; i < 16; ++i) {
    const int want = i == a || i == b || i == c;
    if (!!bits[i] != want) return 0;
  }
  return 1;
}

static void examples(modbus_t* ctx) {
  uint8_t bits[16];
  uint16_t regs[16], back[16];
  int ok;

  /* Example 1: preparation and return to origin. */
  check(modbus_write_bit(ctx, 0x30, 1) == 1, "Y30 <- 1 (serial input mode)");
  check(modbus_write_bit(ctx, 0x19, 1) == 1, "Y19 <- 1 (SVON)");
  check(wait_flags(ctx, SVRE, 1, -1, 0, bits) == 0 && only(bits, SVRE, -1, -1),
        "SVRE = 1, X40-X4F = only SVRE (manual reply 01 02 02 00 02)");
  check(modbus_write_bit(ctx, 0x1C, 1) == 1, "Y1C <- 1 (SETUP)");
  check(wait_flags(ctx, SETON, 1, BUSY, 0, bits) == 0 && only(bits, SVRE, SETON, INP),
        "SETON = 1 and BUSY = 0; X40-X4F = SVRE+SETON+INP (manual reply 01 02 02 00 0E)");
  check(modbus_write_bit(ctx, 0x1C, 0) == 1, "Y1C <- 0");

  /* Example 2: the whole record of step 1, position 150.00. */
  record(regs, 15000);
  check(modbus_write_registers(ctx, step_address(1), 16, regs) == 16, "FC10 step 1 x16");
  check(modbus_read_registers(ctx, step_address(1), 16, back) == 16 &&
            memcmp(regs, back, sizeof regs) == 0,
        "step 1 reads back as written");

  /* Example 1 continued: IN0-IN5 = 1 with FC0F Y10 x8, DRIVE. */
  const uint8_t step1[8] = {1, 0, 0, 0, 0, 0, 0, 0};
  check(modbus_write_bits(ctx, 0x10, 8, step1) == 8, "FC0F Y10 x8 = step 1");
  check(modbus_write_bit(ctx, 0x1A, 1) == 1, "Y1A <- 1 (DRIVE)");
  check(wait_flags(ctx, BUSY, 0, INP, 1, bits) == 0, "BUSY fell with INP = 1");
  check(modbus_write_bit(ctx, 0x1A, 0) == 1, "Y1A <- 0");

  /* Example 3: read the position. */
  int32_t pos = read_position(ctx, &ok);
  check(ok && pos == 15000, "D9000 x2 = 15000 (150.00 mm), got %d", pos);

  /* Example 4: direct operation to 300.00. */
  record(regs, 30000);
  check(modbus_write_registers(ctx, 0x9102, 16, regs) == 16, "FC10 D9102 x16 (300.00 mm)");
  const uint16_t start = 0x0100;
  check(modbus_write_registers(ctx, 0x9100, 1, &start) == 1, "FC10 D9100 <- 0100h");
  check(wait_flags(ctx, BUSY, 0, INP, 1, bits) == 0, "BUSY fell with INP = 1");
  pos = read_position(ctx, &ok);
  check(ok && pos == 30000, "D9000 x2 = 30000 (300.00 mm), got %d", pos);
}

static void expect_errno(int rc, int want, const char* what) {
  const int err = errno;
  check(rc == -1 && err == want, "%s -> %s (rc %d, %s)", what, modbus_strerror(want), rc,
        rc == -1 ? modbus_strerror(err) : "no error");
}

static void exceptions(modbus_t* ctx) {
  uint16_t regs[8];
  uint8_t bits[16];
  const uint16_t zero[2] = {0, 0};

  expect_errno(modbus_read_input_registers(ctx, 0x9000, 2, regs), EMBXILFUN, "FC04");
  expect_errno(modbus_write_register(ctx, 0x0410, 1), EMBXILFUN, "FC06");
  expect_errno(modbus_read_registers(ctx, 0x9000, 0, regs), EMBXILVAL, "FC03 count 0");
  expect_errno(modbus_read_registers(ctx, 0x0000, 1, regs), EMBXILADD, "FC03 D0000 outside");
  expect_errno(modbus_read_input_bits(ctx, 0x48, 16, bits), EMBXILVAL, "FC02 X48 x16 beyond X4F");
  expect_errno(modbus_write_registers(ctx, 0x9000, 2, zero), EMBXILADD, "FC10 D9000 read-only");
  expect_errno(modbus_write_bit(ctx, 0x31, 1), EMBXILADD, "FC05 Y31 not permitted");
}

/* FC08 echo: sent raw, its reply read from the descriptor (see the top). */
static void echo(modbus_t* ctx) {
  const uint8_t req[] = {1, 0x08, 0x00, 0x00, 0xA5, 0x5A};
  const int sent = modbus_send_raw_request(ctx, req, (int)sizeof req);
  check(sent == (int)sizeof req + 2, "FC08 sent raw (%d bytes)", sent);
  uint8_t got[16];
  size_t n = 0;
  const int fd = modbus_get_socket(ctx);
  const double deadline = now_s() + 1.0;
  while (n < 8 && now_s() < deadline) {
    struct pollfd p = {fd, POLLIN, 0};
    const int left = (int)((deadline - now_s()) * 1000) + 1;
    if (poll(&p, 1, left) <= 0) continue;
    const ssize_t r = read(fd, got + n, sizeof got - n);
    if (r > 0) n += (size_t)r;
  }
  /* The reply is the request, CRC included: 01 08 00 00 A5 5A + CRC. */
  check(n == 8 && memcmp(got, req, sizeof req) == 0, "FC08 echo comes back (%zu bytes)", n);
}

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s PORT\n", argv[0]);
    return 2;
  }
  modbus_t* ctx = modbus_new_rtu(argv[1], 38400, 'N', 8, 1);
  if (!ctx) {
    fprintf(stderr, "modbus_new_rtu: %s\n", modbus_strerror(errno));
    return 1;
  }
  modbus_set_slave(ctx, 1);
  modbus_set_response_timeout(ctx, 1, 0);
  if (modbus_connect(ctx) != 0) {
    fprintf(stderr, "modbus_connect %s: %s\n", argv[1], modbus_strerror(errno));
    modbus_free(ctx);
    return 1;
  }
  examples(ctx);
  exceptions(ctx);
  echo(ctx);
  modbus_close(ctx);
  modbus_free(ctx);
  printf("%d passed, %d failed\n", passed, failed);
  return failed == 0 && passed > 0 ? 0 : 1;
}
