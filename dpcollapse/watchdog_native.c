/* The stop watchdog's thread (dpcollapse/watchdog.py): a native thread, so that it runs
 * while the main thread holds Python's GIL inside a C library (petsc4py keeps the GIL
 * through a MUMPS factorization: a Python thread would wait with it).
 *
 * It blocks on the read end of Python's signal wake-up pipe (signal.set_wakeup_fd: the
 * signal number is written by the C-level handler, wherever the main thread is). After
 * SIGINT or SIGTERM it first writes the prepared early run.json at once (status
 * interrupted: "a stop request arrived during a step after the last checkpoint"; the
 * process may be ended before that step finishes, e.g. by mpirun 1 s after it forwarded
 * the signal, and run.json must not stay "running"), then waits STOP_BOUND seconds for the main thread to reach a safe point
 * (dpc_safe_point, called at the end of every time step); if none comes, it writes the
 * prepared run.json (status interrupted, the reason) atomically, writes the prepared line
 * to stderr and leaves with _exit(130). Nothing here allocates or calls Python after the
 * signal, except the mutex-guarded copy of the prepared texts. */
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int wake_fd = -1;
static double bound_seconds = 20.0;
static volatile long safe_points = 0;
static volatile int armed = 0;
static int final_written = 0;   /* the main thread writes its own last run.json (dpc_final) */
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static char *record = NULL, *record_path = NULL, *record_tmp = NULL, *line = NULL;
static char *early = NULL;
static size_t record_len = 0, line_len = 0, early_len = 0;

void dpc_safe_point(void) { __atomic_add_fetch(&safe_points, 1, __ATOMIC_SEQ_CST); }

void dpc_arm(double bound) {
    pthread_mutex_lock(&lock);
    final_written = 0;
    pthread_mutex_unlock(&lock);
    bound_seconds = bound;
    __atomic_store_n(&armed, 1, __ATOMIC_SEQ_CST);
}

/* The main thread is about to write its own last run.json (the run ends: completed,
 * failed or interrupted at a safe point). Under the mutex: an early write in progress
 * finishes (rename included) before this returns, so the main thread's write comes after
 * it and wins; an early write not yet begun sees the flag and is skipped. */
void dpc_final(void) {
    pthread_mutex_lock(&lock);
    final_written = 1;
    pthread_mutex_unlock(&lock);
}

static char *copy(const char *text, size_t n) {
    char *out = malloc(n + 1);
    if (out) { memcpy(out, text, n); out[n] = 0; }
    return out;
}

/* The run.json to write (path, its temporary name, the text if the bound passes, the
 * early text written at once on the signal) and the stderr line. */
int dpc_prepare(const char *path, const char *tmp, const char *text, size_t n,
                const char *early_text, size_t e, const char *message, size_t m) {
    char *p = copy(path, strlen(path)), *t = copy(tmp, strlen(tmp)),
         *r = text ? copy(text, n) : NULL, *x = early_text ? copy(early_text, e) : NULL,
         *l = copy(message, m);
    if (!p || !t || (text && !r) || (early_text && !x) || !l) {
        free(p); free(t); free(r); free(x); free(l);
        return -1;
    }
    pthread_mutex_lock(&lock);
    free(record_path); free(record_tmp); free(record); free(early); free(line);
    record_path = p; record_tmp = t; record = r; record_len = n; early = x; early_len = e;
    line = l; line_len = m;
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

/* text -> record_tmp, fsync, rename onto record_path (the caller holds the mutex). */
static void write_record(const char *text, size_t n) {
    if (!text || !record_path || !record_path[0] || !record_tmp) return;
    int fd = open(record_tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) return;
    write_all(fd, text, n);
    fsync(fd);
    close(fd);
    rename(record_tmp, record_path);
}

/* Whether run.json still says "running" (or cannot be read): the early record replaces
 * nothing else, e.g. not the "failed" another rank wrote before it ended the job with
 * MPI_Abort (Open MPI then sends SIGTERM to this rank). Its first key is "status"
 * (RunInfo); a static buffer, no allocation (the caller holds the mutex). */
static int still_running(void) {
    static char head[4097];
    size_t n = 0;
    int fd = open(record_path, O_RDONLY);
    if (fd < 0) return 1;
    while (n < sizeof head - 1) {
        ssize_t r = read(fd, head + n, sizeof head - 1 - n);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        n += (size_t)r;
    }
    close(fd);
    head[n] = 0;
    char *p = strstr(head, "\"status\"");
    if (!p) return 1;
    p += 8;
    while (*p == ' ' || *p == ':' || *p == '\n' || *p == '\t') p++;
    return strncmp(p, "\"running\"", 9) == 0;
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
    /* The early record, at once. Race with the main thread's own run.json: both are
     * atomic renames, and the main thread's last write must win. It comes after a safe
     * point (the loop honours the request after dpc_safe_point) and after dpc_final, which
     * takes this mutex: either this write (rename included) is over before dpc_final
     * returns, so the main thread's write replaces it, or final_written is set and this
     * write is skipped. It is skipped too if a safe point was passed since the signal was
     * read (the loop is then stopping by itself), and if run.json no longer says
     * "running" (another rank's record). It happens before the wait below. */
    int early_written = 0;
    pthread_mutex_lock(&lock);
    if (!final_written && __atomic_load_n(&safe_points, __ATOMIC_SEQ_CST) == seen
            && early && record_path && record_path[0] && still_running()) {
        write_record(early, early_len);
        early_written = 1;
    }
    pthread_mutex_unlock(&lock);
    while (now() - start < bound_seconds) {
        struct timespec ts = {0, 20000000};
        nanosleep(&ts, NULL);
        if (__atomic_load_n(&safe_points, __ATOMIC_SEQ_CST) != seen)
            return NULL;   /* the loop reached a safe point: it honours the stop */
    }
    pthread_mutex_lock(&lock);
    /* not over the main thread's own last run.json, nor over another rank's record */
    if (!final_written && record && record_path && record_path[0]
            && (early_written || still_running()))
        write_record(record, record_len);
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
