/*
 * odocal-avr-board: an ATmega328P (or another simavr part) running a
 * firmware ELF, its UART0 on a pseudo-terminal, its EEPROM in a file.
 *
 *   odocal-avr-board --elf odolink_avr.elf --eeprom robot.eeprom
 *   -> prints "pty /dev/pts/N" once, then runs until SIGTERM / SIGINT.
 *
 * The EEPROM file behaves like the part's EEPROM across power cuts: it is
 * mapped MAP_SHARED and simavr's EEPROM array is pointed at the mapping, so
 * every byte the firmware writes lands in the kernel's page cache for that
 * file the moment the simulated write happens. `kill -9` at any instant
 * leaves the file with exactly the bytes written so far, like pulling the
 * power between two EEPROM byte writes.
 *
 * The pty: simavr's uart_pty part creates it (raw, slave name in the
 * struct, never the /tmp/simavr-uart0 symlink that uart_pty_connect makes and
 * that two boards running at once would fight over) and takes the firmware's
 * output through its IRQ into its FIFO. Its thread is not used: it stops
 * servicing a read it could not fully queue until the firmware happens to
 * send something (a select with no fd set), so a host burst of more than
 * ~500 bytes deadlocks it; and its stock connect raises received bytes into
 * the core from that thread while the core runs. Here the core thread alone
 * services the pty master: it reads only as many bytes as the simulated
 * UART's receive FIFO has room for (the rest waits in the kernel's pty
 * buffer, so nothing is dropped and the host's writes block when it is full)
 * and the UART delivers them to the firmware at the configured baud rate.
 * Output that the host does not read stays queued (64 KiB here, then the
 * kernel's pty buffer); beyond that it is dropped, like a UART nobody
 * listens to.
 *
 * Time: the core runs no faster than real time (it sleeps when simulated
 * time is ahead of the wall clock, both while the firmware executes and while
 * it sleeps), and as fast as the host allows when behind.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <avr_eeprom.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_irq.h>
#include <uart_pty.h>

/* The headers only declare the FIFOs; these define their (static inline)
 * accessors for this file. */
DEFINE_FIFO(uint8_t, uart_pty_fifo);
DEFINE_FIFO(uint16_t, uart_fifo);

static volatile sig_atomic_t stop_signal;

static void on_signal(int sig) { stop_signal = sig; }

static void die(const char* fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void die(const char* fmt, ...) {
  va_list ap;
  fputs("odocal-avr-board: ", stderr);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fputc('\n', stderr);
  exit(1);
}

static void usage(FILE* to) {
  fprintf(to,
          "usage: odocal-avr-board --elf FILE --eeprom IMAGE [--mcu atmega328p] [--freq 16000000]\n"
          "                        [--eeprom-write-us 3400] [--cut-after-writes N]\n"
          "  Runs FILE under simavr with UART0 on a new pseudo-terminal and the EEPROM\n"
          "  persisted in IMAGE (created 0xFF-filled if missing). Prints \"pty /dev/pts/N\"\n"
          "  on stdout once the terminal is ready; runs until SIGTERM or SIGINT.\n"
          "  --eeprom-write-us US: time an EEPROM byte write keeps the part busy\n"
          "  (default 3400, as on the part; 0: instant, simavr's own behaviour).\n"
          "  --cut-after-writes N (testing): die like a power cut right after the Nth\n"
          "  EEPROM byte the firmware changes.\n");
}

/* ---- EEPROM ---------------------------------------------------------- */

static avr_io_t* find_io(avr_t* avr, const char* kind, int uart_name) {
  avr_io_t* io;
  for (io = avr->io_port; io != NULL; io = io->next) {
    if (io->kind == NULL || strcmp(io->kind, kind) != 0) continue;
    if (uart_name && ((avr_uart_t*)io)->name != uart_name) continue;
    return io;
  }
  return NULL;
}

/* Creates IMAGE as `size` bytes of 0xFF (an erased EEPROM) under a temporary
 * name, then renames it into place: a kill during creation leaves either no
 * image or a complete one, never a short file. */
static void create_image(const char* path, size_t size) {
  char tmp[4096];
  uint8_t* erased;
  int fd;
  if (snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid()) >= (int)sizeof tmp) {
    die("%s: path too long", path);
  }
  fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) die("%s: %s", tmp, strerror(errno));
  erased = malloc(size);
  if (erased == NULL) die("out of memory");
  memset(erased, 0xFF, size);
  if (write(fd, erased, size) != (ssize_t)size || fsync(fd) != 0) {
    die("%s: %s", tmp, strerror(errno));
  }
  free(erased);
  close(fd);
  if (rename(tmp, path) != 0) die("%s: %s", path, strerror(errno));
}

static uint8_t* map_eeprom(avr_t* avr, const char* path, size_t* size_out) {
  avr_eeprom_t* ee = (avr_eeprom_t*)find_io(avr, "eeprom", 0);
  struct stat st;
  uint8_t* map;
  int fd;
  if (ee == NULL || ee->eeprom == NULL || ee->size == 0) die("the %s has no EEPROM", avr->mmcu);
  if (access(path, F_OK) != 0) {
    if (errno != ENOENT) die("%s: %s", path, strerror(errno));
    create_image(path, ee->size);
  }
  fd = open(path, O_RDWR | O_CLOEXEC);
  if (fd < 0) die("%s: %s", path, strerror(errno));
  /* One board per image: two would both think they own the part. */
  if (flock(fd, LOCK_EX | LOCK_NB) != 0) die("%s: in use by another board (%s)", path, strerror(errno));
  if (fstat(fd, &st) != 0) die("%s: %s", path, strerror(errno));
  if (st.st_size != (off_t)ee->size) {
    die("%s: %lld bytes, but the %s's EEPROM holds %u bytes (wrong image?)", path,
        (long long)st.st_size, avr->mmcu, (unsigned)ee->size);
  }
  map = mmap(NULL, ee->size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  if (map == MAP_FAILED) die("%s: mmap: %s", path, strerror(errno));
  /* fd stays open: it holds the lock. The array simavr allocated (and that
   * avr_load_firmware may have filled from the ELF's .eeprom section) is
   * replaced: the image is the part's EEPROM. simavr never frees it. */
  free(ee->eeprom);
  ee->eeprom = map;
  *size_out = ee->size;
  return map;
}

/* ---- EEPROM write time, and a power cut at a chosen write ------------ */

/* simavr performs an EEPROM byte write instantly and clears EEPE at once, so
 * the firmware never waits; the real part takes 3.4 ms per byte (datasheet
 * tWD_EEPROM 3.3 ms), during which EEPE reads 1 and avr-libc's
 * eeprom_busy_wait spins. The board wraps the EEPROM control register's write
 * handler to put that time back (--eeprom-write-us, 0 for simavr's instant
 * writes): a push then takes as long as on the part, and a kill -9 during a
 * push lands inside a record write as often as a power cut would.
 *
 * --cut-after-writes N (a test aid): the board dies (_exit, nothing flushed
 * or cleaned, like kill -9) right after the Nth EEPROM byte that changes. */
static struct {
  avr_eeprom_t* ee;
  avr_io_write_t inner;
  void* inner_param;
  uint32_t write_us;
  unsigned long cut_remaining; /* 0: not armed */
  uint8_t* image;
  uint8_t* shadow;
  size_t size;
} eew;

static avr_cycle_count_t eeprom_write_done(avr_t* avr, avr_cycle_count_t when, void* param) {
  (void)when;
  (void)param;
  avr_regbit_clear(avr, eew.ee->eepe);
  return 0;
}

static void eecr_write_hook(avr_t* avr, avr_io_addr_t addr, uint8_t v, void* param) {
  const int starts_write = avr_regbit_get(avr, eew.ee->eempe) && ((v >> eew.ee->eepe.bit) & 1u);
  size_t i;
  (void)param;
  if (avr_regbit_get(avr, eew.ee->eepe)) {
    /* Still busy: the part ignores a new write; keep EEPE set. */
    avr->data[addr] = (uint8_t)(v | (1u << eew.ee->eepe.bit));
    return;
  }
  eew.inner(avr, addr, v, eew.inner_param);
  if (starts_write && eew.write_us > 0) {
    avr_regbit_set(avr, eew.ee->eepe);
    avr_cycle_timer_register_usec(avr, eew.write_us, eeprom_write_done, NULL);
  }
  if (eew.cut_remaining == 0) return;
  for (i = 0; i < eew.size; ++i) {
    if (eew.image[i] == eew.shadow[i]) continue;
    eew.shadow[i] = eew.image[i];
    if (--eew.cut_remaining == 0) {
      fprintf(stderr, "odocal-avr-board: power cut after EEPROM byte 0x%03zx was written\n", i);
      _exit(137);
    }
  }
}

static void wrap_eeprom(avr_t* avr, uint8_t* image, size_t size, uint32_t write_us,
                        unsigned long cut_after) {
  int io;
  eew.ee = (avr_eeprom_t*)find_io(avr, "eeprom", 0);
  io = AVR_DATA_TO_IO(eew.ee->r_eecr);
  eew.write_us = write_us;
  eew.cut_remaining = cut_after;
  eew.image = image;
  eew.size = size;
  eew.shadow = malloc(size);
  if (eew.shadow == NULL) die("out of memory");
  memcpy(eew.shadow, image, size);
  eew.inner = avr->io[io].w.c;
  eew.inner_param = avr->io[io].w.param;
  if (eew.inner == NULL) die("no EEPROM control register handler to wrap");
  avr->io[io].w.c = eecr_write_hook;
}

/* ---- UART0 <-> pty ---------------------------------------------------- */

#define BRIDGE_OUT_CAP 65536u

typedef struct {
  uart_pty_t pty;
  avr_uart_t* uart;
  avr_irq_t* uart_input;
  int master;
  uint8_t out[BRIDGE_OUT_CAP]; /* firmware output not yet taken by the kernel */
  size_t out_len;
  unsigned long out_dropped;
} bridge_t;

static void bridge_init(avr_t* avr, bridge_t* b) {
  uint32_t flags = 0;
  avr_irq_t* uart_output;
  struct termios tio;
  int slave;

  b->uart = (avr_uart_t*)find_io(avr, "uart", '0');
  if (b->uart == NULL) die("the %s has no UART0", avr->mmcu);
  /* No "tap" second pty, no xterm. */
  unsetenv("SIMAVR_UART_TAP");
  unsetenv("SIMAVR_UART_XTERM");
  uart_pty_init(avr, &b->pty);
  if (b->pty.pty.s <= 0 || b->pty.pty.slavename[0] == '\0') die("cannot create a pseudo-terminal");
  /* Its thread sits in select() (a cancellation point); no host has the
   * slave yet, so no byte is in flight. */
  pthread_cancel(b->pty.thread);
  pthread_join(b->pty.thread, NULL);
  b->master = b->pty.pty.s;
  if (fcntl(b->master, F_SETFL, fcntl(b->master, F_GETFL) | O_NONBLOCK) != 0) {
    die("pty: %s", strerror(errno));
  }

  /* Binary data: no console echo of the bytes (STDIO), and no usleep when
   * the firmware polls the status register (POLL_SLEEP would make every
   * blocking transmit take milliseconds per byte). */
  avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);

  uart_output = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT);
  b->uart_input = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  if (uart_output == NULL || b->uart_input == NULL) die("UART0 has no IRQs");
  avr_connect_irq(uart_output, b->pty.irq + IRQ_UART_PTY_BYTE_IN);

  /* The slave raw from the start: with the default line discipline a byte the
   * firmware sends while no host has the port open would be echoed back into
   * the firmware, and 0x0D turned into 0x0A. uart_pty keeps a slave fd open,
   * so the settings hold between host sessions and the master never sees
   * EIO. */
  slave = open(b->pty.pty.slavename, O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (slave < 0) die("%s: %s", b->pty.pty.slavename, strerror(errno));
  if (tcgetattr(slave, &tio) == 0) {
    cfmakeraw(&tio);
    cfsetispeed(&tio, B115200);
    cfsetospeed(&tio, B115200);
    tcsetattr(slave, TCSANOW, &tio);
  }
  close(slave);
}

/* Room in the simulated UART's receive FIFO. */
static size_t bridge_rx_room(bridge_t* b) {
  if (!avr_regbit_get(b->uart->io.avr, b->uart->rxen)) return 0; /* a disabled receiver drops */
  return uart_fifo_get_write_size(&b->uart->input);
}

/* Core thread: host bytes into the UART (only what fits), firmware bytes to
 * the host. */
static void bridge_pump(bridge_t* b) {
  size_t room = bridge_rx_room(b);
  while (room > 0) {
    uint8_t in[64];
    ssize_t i, n = read(b->master, in, room < sizeof in ? room : sizeof in);
    if (n <= 0) break; /* EAGAIN: nothing waiting */
    for (i = 0; i < n; ++i) avr_raise_irq(b->uart_input, in[i]);
    room -= (size_t)n;
  }
  while (!uart_pty_fifo_isempty(&b->pty.pty.in)) {
    const uint8_t byte = uart_pty_fifo_read(&b->pty.pty.in);
    if (b->out_len < BRIDGE_OUT_CAP) {
      b->out[b->out_len++] = byte;
    } else {
      ++b->out_dropped;
    }
  }
  if (b->out_len > 0) {
    const ssize_t n = write(b->master, b->out, b->out_len);
    if (n > 0) {
      memmove(b->out, b->out + n, b->out_len - (size_t)n);
      b->out_len -= (size_t)n;
    }
  }
}

/* ---- Time ------------------------------------------------------------ */

static struct timespec wall_base;  /* wall clock when simulated cycle 0 ran */
static uint64_t sim_frequency;

static uint64_t ts_ns(const struct timespec* t) {
  return (uint64_t)t->tv_sec * 1000000000u + (uint64_t)t->tv_nsec;
}

/* Simulated time of `cycle` in ns, without overflow for any run length. */
static uint64_t cycle_ns(uint64_t cycle) {
  return cycle / sim_frequency * 1000000000u + cycle % sim_frequency * 1000000000u / sim_frequency;
}

/* Sleeps until the wall clock reaches simulated cycle `cycle`. If the
 * simulation is far behind (the host was busy or stopped), it forgives the
 * backlog instead of racing to catch up. */
static void sync_to_wall(uint64_t cycle) {
  struct timespec now;
  const uint64_t sim_ns = cycle_ns(cycle);
  uint64_t target, now_ns;
  clock_gettime(CLOCK_MONOTONIC, &now);
  target = ts_ns(&wall_base) + sim_ns;
  now_ns = ts_ns(&now);
  if (target > now_ns) {
    struct timespec t;
    t.tv_sec = (time_t)(target / 1000000000u);
    t.tv_nsec = (long)(target % 1000000000u);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, NULL) == EINTR && !stop_signal) {
    }
  } else if (now_ns - target > 200000000u) {
    const uint64_t base = now_ns - sim_ns;
    wall_base.tv_sec = (time_t)(base / 1000000000u);
    wall_base.tv_nsec = (long)(base % 1000000000u);
  }
}

static bridge_t* sleep_bridge;

/* The firmware executes SLEEP (its main loop is idle): move what the pty
 * has, then wait until the next timer is due, or less if the host sends
 * something the UART can take (its interrupt wakes the part; the simulated
 * clock still counts the whole sleep, and the pacing in main() lets the wall
 * clock catch up). An idle firmware sleeps between 1 ms ticks, so this is
 * where a request's bytes get in without waiting for main()'s next pump. */
static void sleep_callback(avr_t* avr, avr_cycle_count_t how_long) {
  struct timespec now;
  uint64_t target, now_ns;
  bridge_t* const b = sleep_bridge;
  bridge_pump(b);
  if (bridge_rx_room(b) == 0 || b->out_len > 0) {
    sync_to_wall(avr->cycle + how_long);
    return;
  }
  clock_gettime(CLOCK_MONOTONIC, &now);
  target = ts_ns(&wall_base) + cycle_ns(avr->cycle + how_long);
  now_ns = ts_ns(&now);
  if (target > now_ns) {
    struct pollfd pfd;
    struct timespec timeout;
    pfd.fd = b->master;
    pfd.events = POLLIN;
    timeout.tv_sec = (time_t)((target - now_ns) / 1000000000u);
    timeout.tv_nsec = (long)((target - now_ns) % 1000000000u);
    if (ppoll(&pfd, 1, &timeout, NULL) > 0) bridge_pump(b);
  }
}

/* ---- Main ------------------------------------------------------------ */

/* The command line. */
typedef struct {
  const char* elf_path;
  const char* eeprom_path;
  const char* mcu;
  unsigned long freq;
  unsigned long cut_after;
  unsigned long eeprom_write_us;
} board_args_t;

/* Reads the options into `a`; -1 to go on, else the exit code (help, misuse). */
static int parse_args(int argc, char** argv, board_args_t* a) {
  static const struct option options[] = {
      {"elf", required_argument, NULL, 'e'},   {"eeprom", required_argument, NULL, 'p'},
      {"mcu", required_argument, NULL, 'm'},   {"freq", required_argument, NULL, 'f'},
      {"cut-after-writes", required_argument, NULL, 'c'},
      {"eeprom-write-us", required_argument, NULL, 'w'},
      {"help", no_argument, NULL, 'h'},        {NULL, 0, NULL, 0}};
  int opt;
  a->elf_path = NULL;
  a->eeprom_path = NULL;
  a->mcu = "atmega328p";
  a->freq = 16000000ul;
  a->cut_after = 0;
  a->eeprom_write_us = 3400;
  while ((opt = getopt_long(argc, argv, "", options, NULL)) != -1) {
    switch (opt) {
      case 'e':
        a->elf_path = optarg;
        break;
      case 'p':
        a->eeprom_path = optarg;
        break;
      case 'm':
        a->mcu = optarg;
        break;
      case 'f': {
        char* end;
        a->freq = strtoul(optarg, &end, 10);
        if (*end != '\0' || a->freq == 0) die("--freq: not a frequency in Hz: %s", optarg);
        break;
      }
      case 'c': {
        char* end;
        a->cut_after = strtoul(optarg, &end, 10);
        if (*end != '\0' || a->cut_after == 0) die("--cut-after-writes: not a count: %s", optarg);
        break;
      }
      case 'w': {
        char* end;
        a->eeprom_write_us = strtoul(optarg, &end, 10);
        if (*end != '\0' || a->eeprom_write_us > 1000000ul) die("--eeprom-write-us: not a time in us: %s", optarg);
        break;
      }
      case 'h': usage(stdout); return 0;
      default: usage(stderr); return 2;
    }
  }
  if (a->elf_path == NULL || a->eeprom_path == NULL || optind != argc) {
    usage(stderr);
    return 2;
  }
  return -1;
}

/* simavr and uart_pty print progress on stdout; stdout is ours for the one
 * "pty" line, so everything else goes to stderr. The returned stream is the
 * real stdout. */
static FILE* take_stdout(void) {
  FILE* out;
  const int saved_stdout = dup(STDOUT_FILENO);
  if (saved_stdout < 0 || dup2(STDERR_FILENO, STDOUT_FILENO) < 0) die("dup: %s", strerror(errno));
  out = fdopen(saved_stdout, "w");
  if (out == NULL) die("fdopen: %s", strerror(errno));
  return out;
}

/* The part with the firmware loaded, at the given clock. */
static avr_t* load_part(const board_args_t* a, elf_firmware_t* fw) {
  avr_t* avr;
  if (access(a->elf_path, R_OK) != 0) die("%s: %s", a->elf_path, strerror(errno));
  if (elf_read_firmware(a->elf_path, fw) != 0) die("%s: not a readable AVR ELF file", a->elf_path);
  avr = avr_make_mcu_by_name(a->mcu);
  if (avr == NULL) die("unknown part: %s", a->mcu);
  avr_init(avr);
  avr->log = LOG_ERROR;
  snprintf(fw->mmcu, sizeof fw->mmcu, "%s", a->mcu);
  fw->frequency = (uint32_t)a->freq;
  avr_load_firmware(avr, fw);
  avr->frequency = (uint32_t)a->freq;
  sim_frequency = a->freq;
  return avr;
}

/* The pty thread must not take SIGTERM / SIGINT (its select would fail
 * and the thread end): block them while it is created, then take them here. */
static void start_bridge(avr_t* avr, bridge_t* bridge) {
  sigset_t block, old;
  struct sigaction sa;
  sigemptyset(&block);
  sigaddset(&block, SIGTERM);
  sigaddset(&block, SIGINT);
  pthread_sigmask(SIG_BLOCK, &block, &old);
  bridge_init(avr, bridge);
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigaction(SIGTERM, &sa, NULL);
  sigaction(SIGINT, &sa, NULL);
  pthread_sigmask(SIG_SETMASK, &old, NULL);
}

/* Runs the core until a signal stops it: 0, or 3 when the firmware can never
 * wake up or the core crashed. */
static int run_until_stopped(avr_t* avr, bridge_t* bridge) {
  while (!stop_signal) {
    int i, state = cpu_Running;
    /* ~2000 instructions (about 0.15 ms at 16 MHz) between pumps. */
    for (i = 0; i < 2000; ++i) {
      state = avr_run(avr);
      if (state == cpu_Done || state == cpu_Crashed) break;
    }
    if (state == cpu_Done) {
      fprintf(stderr, "odocal-avr-board: the firmware went to sleep with interrupts disabled "
                      "(it can never wake up) at cycle %llu\n", (unsigned long long)avr->cycle);
      return 3;
    }
    if (state == cpu_Crashed) {
      fprintf(stderr, "odocal-avr-board: the core crashed (pc 0x%05x, cycle %llu)\n",
              (unsigned)avr->pc, (unsigned long long)avr->cycle);
      return 3;
    }
    bridge_pump(bridge);
    /* Running code: hold simulated time within ~1 ms ahead of the wall. */
    {
      struct timespec now;
      const uint64_t sim_ns = cycle_ns(avr->cycle);
      clock_gettime(CLOCK_MONOTONIC, &now);
      if (ts_ns(&wall_base) + sim_ns > ts_ns(&now) + 1000000u) sync_to_wall(avr->cycle);
    }
  }
  return 0;
}

int main(int argc, char** argv) {
  static elf_firmware_t fw;
  static bridge_t bridge;
  board_args_t args;
  avr_t* avr;
  uint8_t* eeprom;
  size_t eeprom_size;
  FILE* out;
  int code = parse_args(argc, argv, &args);
  if (code >= 0) return code;

  out = take_stdout();
  avr = load_part(&args, &fw);
  eeprom = map_eeprom(avr, args.eeprom_path, &eeprom_size);
  wrap_eeprom(avr, eeprom, eeprom_size, (uint32_t)args.eeprom_write_us, args.cut_after);
  start_bridge(avr, &bridge);

  sleep_bridge = &bridge;
  avr->sleep = sleep_callback;
  clock_gettime(CLOCK_MONOTONIC, &wall_base);

  fprintf(out, "pty %s\n", bridge.pty.pty.slavename);
  fflush(out);

  code = run_until_stopped(avr, &bridge);
  if (code != 0) return code;
  msync(eeprom, eeprom_size, MS_SYNC);
  return 0;
}
