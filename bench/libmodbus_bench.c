/* The `lec bench` workload on Debian's libmodbus (3.1), for bench/compare.
 *
 *   lec6_libmodbus_bench PORT BAUD OP N [ID]
 *
 * OP: read-state (FC03 D9000 x7) or read-flags (FC02 X40 x16). One warm-up
 * transaction, then N timed ones, back to back, as fast as libmodbus goes
 * (it waits no silent interval before a query). Latency: the call to
 * modbus_read_registers / modbus_read_input_bits until it returns.
 * Prints one JSON object with the keys `lec bench --json` uses; exit status 1
 * if any transaction failed. */

#include <errno.h>
#include <modbus.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_s(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + (double)t.tv_nsec / 1e9;
}

static int cmp_double(const void* a, const void* b) {
  const double x = *(const double*)a, y = *(const double*)b;
  return x < y ? -1 : x > y;
}

/* The same percentile rule as `lec bench`: element floor(p * n), clamped. */
static double pct(const double* sorted, size_t n, double p) {
  size_t i = (size_t)(p * (double)n);
  if (i >= n) i = n - 1;
  return sorted[i];
}

int main(int argc, char** argv) {
  if (argc < 5) {
    fprintf(stderr, "usage: %s PORT BAUD read-state|read-flags N [ID]\n", argv[0]);
    return 2;
  }
  const char* port = argv[1];
  const int baud = atoi(argv[2]);
  const char* op = argv[3];
  const long n = atol(argv[4]);
  const int id = argc > 5 ? atoi(argv[5]) : 1;
  const int state = strcmp(op, "read-state") == 0;
  if (!state && strcmp(op, "read-flags") != 0) {
    fprintf(stderr, "op '%s': expected read-state or read-flags\n", op);
    return 2;
  }
  if (n < 1) {
    fprintf(stderr, "N must be at least 1\n");
    return 2;
  }

  modbus_t* ctx = modbus_new_rtu(port, baud, 'N', 8, 1);
  if (!ctx) {
    fprintf(stderr, "modbus_new_rtu: %s\n", modbus_strerror(errno));
    return 1;
  }
  modbus_set_slave(ctx, id);
  modbus_set_response_timeout(ctx, 0, 500000);
  if (modbus_connect(ctx) != 0) {
    fprintf(stderr, "modbus_connect %s: %s\n", port, modbus_strerror(errno));
    modbus_free(ctx);
    return 1;
  }

  uint16_t regs[7];
  uint8_t bits[16];
  double* lat = malloc((size_t)n * sizeof *lat);
  if (!lat) return 1;
  long errors = 0;
  /* Warm-up. */
  if ((state ? modbus_read_registers(ctx, 0x9000, 7, regs)
             : modbus_read_input_bits(ctx, 0x40, 16, bits)) < 0)
    ++errors;
  size_t done = 0;
  const double start = now_s();
  for (long i = 0; i < n; ++i) {
    const double t0 = now_s();
    const int rc = state ? modbus_read_registers(ctx, 0x9000, 7, regs)
                         : modbus_read_input_bits(ctx, 0x40, 16, bits);
    const double t1 = now_s();
    if (rc < 0) {
      ++errors;
      continue;
    }
    lat[done++] = (t1 - t0) * 1e3;
  }
  const double total = now_s() - start;
  modbus_close(ctx);
  modbus_free(ctx);

  qsort(lat, done, sizeof *lat, cmp_double);
  printf(
      "{\"stack\": \"libmodbus %s\", \"op\": \"%s\", \"n\": %zu, \"errors\": %ld, \"baud\": %d, "
      "\"tx_per_s\": %.3f, \"latency_ms\": {\"p50\": %.4f, \"p99\": %.4f, \"max\": %.4f}}\n",
      LIBMODBUS_VERSION_STRING, op, done, errors, baud, total > 0 ? (double)done / total : 0.0,
      done ? pct(lat, done, 0.5) : 0.0, done ? pct(lat, done, 0.99) : 0.0,
      done ? lat[done - 1] : 0.0);
  free(lat);
  return errors ? 1 : 0;
}
