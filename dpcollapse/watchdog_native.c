/* The stop watchdog's thread (dpcollapse/watchdog.py): a native thread, so that it runs
 * while the main thread holds Python's GIL inside a C library (petsc4py keeps the GIL
 * through a MUMPS factorization: a Python thread would wait with it).
 *
 * It blocks on the read end of Python's signal wake-up pipe (signal.set_wakeup_fd: the
 * signal number is written by the C-level handler, wherever the main thread is). After
 * SIGINT or SIGTERM it waits STOP_BOUND seconds for the main thread to reach a safe point
 * (dpc_safe_point, called at the end of every time step); if none comes, it writes the
 * prepared run.json (status interrupted, the reason) atomically, writes the prepared line
 * to stderr and leaves with _exit(130). Nothing here allocates or calls Python after the
 * signal, except the mutex-guarded copy of the prepared texts. */
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int wake_fd = -1;
static double bound_seconds = 20.0;
static volatile long safe_points = 0;
static volatile int armed = 0;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static char *record = NULL, *record_path = NULL, *record_tmp = NULL, *line = NULL;
static size_t record_len = 0, line_len = 0;

void dpc_safe_point(void) { __atomic_add_fetch(&safe_points, 1, __ATOMIC_SEQ_CST); }

void dpc_arm(double bound) { bound_seconds = bound; __atomic_store_n(&armed, 1, __ATOMIC_SEQ_CST); }

static char *copy(const char *text, size_t n) {
    char *out = malloc(n + 1);
    if (out) { memcpy(out, text, n); out[n] = 0; }
    return out;
}

/* The run.json to write (path, its temporary name, the text) and the stderr line. */
int dpc_prepare(const char *path, const char *tmp, const char *text, size_t n,
                const char *message, size_t m) {
    char *p = copy(path, strlen(path)), *t = copy(tmp, strlen(tmp)),
         *r = text ? copy(text, n) : NULL, *l = copy(message, m);
    if (!p || !t || (text && !r) || !l) { free(p); free(t); free(r); free(l); return -1; }
    pthread_mutex_lock(&lock);
    free(record_path); free(record_tmp); free(record); free(line);
    record_path = p; record_tmp = t; record = r; record_len = n; line = l; line_len = m;
    pthread_mutex_unlock(&lock);
    return 0;
}

static void write_all(int fd, const char *p, size_t n) {
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return;
        p += w; n -= (size_t)w;
    }
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static void *watch(void *unused) {
    (void)unused;
    unsigned char c;
    for (;;) {
        ssize_t r = read(wake_fd, &c, 1);
        if (r < 0 && (errno == EINTR || errno == EAGAIN)) {
            if (errno == EAGAIN) { struct timespec ts = {0, 50000000}; nanosleep(&ts, NULL); }
            continue;
        }
        if (r <= 0) return NULL;
        if ((c == SIGINT || c == SIGTERM) && armed) break;
    }
    long seen = __atomic_load_n(&safe_points, __ATOMIC_SEQ_CST);
    double start = now();
    while (now() - start < bound_seconds) {
        struct timespec ts = {0, 20000000};
        nanosleep(&ts, NULL);
        if (__atomic_load_n(&safe_points, __ATOMIC_SEQ_CST) != seen)
            return NULL;   /* the loop reached a safe point: it honours the stop */
    }
    pthread_mutex_lock(&lock);
    if (record && record_path && record_path[0] && record_tmp) {
        int fd = open(record_tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            write_all(fd, record, record_len);
            fsync(fd);
            close(fd);
            rename(record_tmp, record_path);
        }
    }
    if (line) write_all(2, line, line_len);
    _exit(130);
    return NULL;
}

/* Start the thread on the wake-up pipe's read end; 0 on success. */
int dpc_start(int fd) {
    pthread_t thread;
    pthread_attr_t attr;
    wake_fd = fd;
    pthread_attr_init(&attr);
    pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
    int rc = pthread_create(&thread, &attr, watch, NULL);
    pthread_attr_destroy(&attr);
    return rc;
}
