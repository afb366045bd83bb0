/*
 * omni4-record - records LCM channels into an event log, on the robot or on a host.
 *
 * Like lcm-logger, with one difference that matters at loop rate: LCM keeps at most 30
 * received-but-undelivered messages per subscription by default, so lcm-logger loses samples
 * whenever its thread waits for the CPU longer than 30 messages last (1.5 ms at 20 kHz). Here
 * the queue holds 100000 messages (5 s at 20 kHz, ~13 MB of OMNI4_MOTORS): a stall costs
 * memory, not samples. The log is flushed once a second, so a power cut loses at most that.
 * With --split-mb the log is a series FILE.00, FILE.01, ..., each closed once it holds the size
 * given. A FIFO or a device is written in place (a reader streams the log), a symbolic link to a
 * new file is followed, an existing file is never overwritten (omni4/outfile.h, streaming);
 * every write, the flushes and the close are checked, and the first that fails stops the
 * recording (one line, status 1). Parameter requests (OMNI4_PARAM_REQ) are
 * never written: they may carry the robot's [params] secret in plain text; what they changed is on
 * OMNI4_PARAM_CHANGED, which is.
 */
#include <errno.h>
#include <getopt.h>
#include <lcm/eventlog.h>
#include <lcm/lcm.h>
#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "omni4/lcmtypes/channels.h"
#include "omni4/base/clock.h"
#include "omni4/lcmtypes/eventlog.h"
#include "omni4/base/getopt_exact.h"
#include "omni4/config/outfile.h"
#include "omni4/version.h"

#define RECORD_QUEUE_MESSAGES 100000

static volatile sig_atomic_t g_stop;

struct recorder {
	lcm_eventlog_t *log; /* &ev while a file is open; NULL once one could not be opened */
	lcm_eventlog_t ev;   /* liblcm's writer over out.f */
	struct omni4_out out;
	char base[4000]; /* --out after strftime */
	char path[4096]; /* the file being written */
	int part;        /* -1: one file; else the NN of FILE.NN */
	uint64_t split_bytes, bytes;
	uint64_t written, errors;
	uint64_t requests_skipped; /* OMNI4_PARAM_REQ messages left out */
	int first_errno;
};

static void on_signal(int sig)
{
	(void)sig;
	g_stop = 1;
}

static void usage(FILE *f)
{
	fprintf(
	    f,
	    "usage: omni4-record --out FILE [--lcm URL] [--channel REGEX] [--duration S]\n"
	    "                    [--split-mb MB] [-q]\n"
	    "Records LCM messages into an LCM event log (lcm-logplayer, omni4-ident read it),\n"
	    "with a 100000-message receive queue: a recorder that waits for the CPU or the disk\n"
	    "for a moment loses nothing.\n"
	    "  -o, --out FILE       log to write; strftime conversions (%%Y, %%m, ...) are "
	    "expanded;\n"
	    "                       an existing file is never overwritten; a FIFO or device is\n"
	    "                       written in place (e.g. a reader streaming the log)\n"
	    "  -l, --lcm URL        LCM URL (default: $LCM_DEFAULT_URL, else the robot's,\n"
	    "                       " OMNI4_DEFAULT_LCM_URL ")\n"
	    "  -c, --channel REGEX  channels to record (default: OMNI4_.*); parameter requests\n"
	    "                       (" OMNI4_CHANNEL_PARAM_REQ ": they may carry the secret) are\n"
	    "                       never recorded\n"
	    "  -d, --duration S     stop after S seconds (default: until SIGINT/SIGTERM)\n"
	    "  -s, --split-mb MB    write FILE.00, FILE.01, ...: the next part starts once a part\n"
	    "                       holds MB megabytes\n"
	    "  -q, --quiet          no progress line\n"
	    "  -h, --help           this text\n"
	    "example: omni4-record --out /var/log/omni4/omni4-%%Y%%m%%d-%%H%%M%%S.lcmlog\n");
}

/* A failed write stops the recording: what follows it in the log could not be trusted, and a
 * full disk does not empty itself (README, "Outputs are written carefully"). */
static void count_error(struct recorder *r, int err)
{
	if (!r->errors)
		r->first_errno = err;
	r->errors++;
	g_stop = 1;
}

/* Opens the one file, or the next one of the series; never over an existing file. */
static int open_next(struct recorder *r)
{
	char why[PATH_MAX + 200];

	if (r->part < 0)
		snprintf(r->path, sizeof(r->path), "%s", r->base);
	else
		snprintf(r->path, sizeof(r->path), "%s.%02d", r->base, r->part);
	const int rc = omni4_out_open(&r->out, r->path, 0666, OMNI4_OUT_STREAM, why, sizeof(why));

	if (rc) {
		fprintf(stderr, "omni4-record: %s\n", why);
		return rc;
	}
	r->ev = (lcm_eventlog_t){.f = r->out.f};
	r->log = &r->ev;
	r->bytes = 0;
	return 0;
}

/* Flushes, syncs and closes the file being written; a failure counts as an error. */
static void close_log(struct recorder *r)
{
	char why[PATH_MAX + 200];

	if (!r->log)
		return;
	r->log = NULL;
	const int rc = omni4_out_commit(&r->out, why, sizeof(why));

	if (rc)
		count_error(r, -rc);
}

static void record(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct recorder *r = user;
	if (!r->log || r->errors) /* stopped at the first failed write */
		return;
	if (!strcmp(channel, OMNI4_CHANNEL_PARAM_REQ)) { /* may carry the secret */
		r->requests_skipped++;
		return;
	}
	const int rc = omni4_eventlog_write(r->log, channel, rbuf->recv_utime, rbuf->data,
	                                    (size_t)rbuf->data_size);

	if (rc) {
		count_error(r, -rc);
		return;
	}
	r->written++;
	r->bytes += OMNI4_EVENT_HEADER_BYTES + strlen(channel) + (uint64_t)rbuf->data_size;
	if (r->part >= 0 && r->bytes >= r->split_bytes) {
		close_log(r);
		r->part++;
		if (open_next(r)) {
			count_error(r, EIO);
			g_stop = 1;
		}
	}
}

static double mono_s(void)
{
	return (double)omni4_monotonic_ns() * 1e-9;
}

/* Parses a positive number within [lo, hi]; false (and a one-line error) otherwise. */
static bool parse_number(const char *opt, const char *arg, double lo, double hi, double *out)
{
	char *end;
	const double v = strtod(arg, &end);

	if (end == arg || *end || !(v >= lo && v <= hi)) {
		fprintf(stderr, "omni4-record: --%s: '%s' is not a number in [%g, %g]\n", opt, arg,
		        lo, hi);
		return false;
	}
	*out = v;
	return true;
}

struct record_args {
	const char *out, *url, *channel;
	double duration, split_mb;
	bool quiet;
};

/* The command line into *a: -1 to go on, else the exit status (0 after --help or --version). */
static int parse_args(int argc, char **argv, struct record_args *a)
{
	static const struct option opts[] = {{"out", required_argument, NULL, 'o'},
	                                     {"lcm", required_argument, NULL, 'l'},
	                                     {"channel", required_argument, NULL, 'c'},
	                                     {"duration", required_argument, NULL, 'd'},
	                                     {"split-mb", required_argument, NULL, 's'},
	                                     {"quiet", no_argument, NULL, 'q'},
	                                     {"help", no_argument, NULL, 'h'},
	                                     {"version", no_argument, NULL, 'V'},
	                                     {NULL, 0, NULL, 0}};
	int c;

	while ((c = omni4_getopt_long("omni4-record", argc, argv, "o:l:c:d:s:qh", opts)) != -1) {
		switch (c) {
		case 'o':
			a->out = optarg;
			break;
		case 'l':
			a->url = optarg;
			break;
		case 'c':
			a->channel = optarg;
			break;
		case 'd':
			if (!parse_number("duration", optarg, 1e-3, 1e9, &a->duration))
				return 2;
			break;
		case 's':
			if (!parse_number("split-mb", optarg, 0.01, 1e6, &a->split_mb))
				return 2;
			break;
		case 'q':
			a->quiet = true;
			break;
		case 'h':
			usage(stdout);
			return 0;
		case 'V':
			printf("omni4-record %s\n", OMNI4_VERSION);
			return 0;
		default: /* '?': omni4_getopt_long said what */
			return 2;
		}
	}
	if (!a->out) {
		fprintf(stderr, "omni4-record: --out FILE is required (see omni4-record --help)\n");
		return 2;
	}
	if (optind != argc) {
		fprintf(stderr,
		        "omni4-record: unexpected argument '%s' (see omni4-record --help)\n",
		        argv[optind]);
		return 2;
	}
	return -1;
}

/* The file name (--out after strftime) and the split size into *r: false after a one-line error. */
static bool name_log(struct recorder *r, const struct record_args *a)
{
	const time_t now = time(NULL);
	struct tm tm;

	r->part = a->split_mb > 0 ? 0 : -1;
	r->split_bytes = (uint64_t)(a->split_mb * 1e6);
	if (!localtime_r(&now, &tm) || !strftime(r->base, sizeof(r->base), a->out, &tm)) {
		fprintf(stderr, "omni4-record: --out '%s' expands to nothing or is too long\n",
		        a->out);
		return false;
	}
	return true;
}

/* Receives and writes until a signal, the duration or an error; a progress line a second. */
static void record_until_stopped(lcm_t *lcm, struct recorder *r, const struct record_args *a)
{
	const bool tty = isatty(STDERR_FILENO);
	const double t0 = mono_s();
	double next_report = t0 + 1.0;
	uint64_t last = 0;

	if (!a->quiet)
		fprintf(stderr, "omni4-record: %s <- %s on %s\n", r->path, a->channel, a->url);
	while (!g_stop && !(a->duration > 0 && mono_s() - t0 >= a->duration)) {
		/* < 0 also when a signal interrupts the wait: only an error if nothing asked to
		 * stop */
		if (lcm_handle_timeout(lcm, 50) < 0 && !g_stop && errno != EINTR) {
			fprintf(stderr, "omni4-record: LCM receive failed; stopping\n");
			count_error(r, EIO);
			break;
		}
		if (mono_s() < next_report)
			continue;
		if (r->log && fflush(r->log->f))
			count_error(r, errno);
		if (!a->quiet)
			fprintf(stderr, "%somni4-record: %7.0f s  %10llu messages  %6llu msg/s%s%s",
			        tty ? "\r" : "", next_report - t0, (unsigned long long)r->written,
			        (unsigned long long)(r->written - last),
			        r->errors ? "  (writes failing)" : "", tty ? "" : "\n");
		last = r->written;
		next_report += 1.0;
	}
}

/* The closing line: what was written, or what failed; the exit status. */
static int report(const struct recorder *r, const struct record_args *a)
{
	const bool tty = isatty(STDERR_FILENO);

	if (r->errors)
		fprintf(stderr, "%somni4-record: %s: %s (stopped at the first failed write)\n",
		        tty && !a->quiet ? "\n" : "", r->path, strerror(r->first_errno));
	else if (!a->quiet)
		fprintf(stderr,
		        "%somni4-record: %s%s: %llu messages (%llu parameter requests left out)\n",
		        tty ? "\n" : "", r->base, r->part >= 0 ? ".NN" : "",
		        (unsigned long long)r->written, (unsigned long long)r->requests_skipped);
	return r->errors ? 1 : 0;
}

/* A udpm URL without a receive buffer of its own asks for RECORD_RCVBUF bytes (the kernel
 * caps it at net.core.rmem_max): a recorder must not lose samples because its process was not
 * scheduled for a moment (the default ~200 kB holds about 0.2 s of the robot's traffic). */
#define RECORD_RCVBUF 4194304
static const char *with_receive_buffer(const char *url, char *buf, size_t n)
{
	if (strncmp(url, "udpm://", 7) != 0 || strstr(url, "recv_buf_size="))
		return url;
	const int k = snprintf(buf, n, "%s%crecv_buf_size=%d", url, strchr(url, '?') ? '&' : '?',
	                       RECORD_RCVBUF);

	return k > 0 && (size_t)k < n ? buf : url;
}

int main(int argc, char **argv)
{
	static struct recorder r;
	char url_buf[512];
	struct record_args a = {.channel = "OMNI4_.*"};
	const int status = parse_args(argc, argv, &a);

	if (status >= 0)
		return status;
	if (!name_log(&r, &a))
		return 2;
	if (!a.url) /* LCM's own convention first, then the robot's default */
		a.url =
		    getenv("LCM_DEFAULT_URL") ? getenv("LCM_DEFAULT_URL") : OMNI4_DEFAULT_LCM_URL;
	lcm_t *lcm = lcm_create(with_receive_buffer(a.url, url_buf, sizeof(url_buf)));

	if (!lcm) {
		fprintf(stderr, "omni4-record: cannot open LCM at '%s'\n", a.url);
		return 1;
	}
	if (open_next(&r)) {
		lcm_destroy(lcm);
		return 1;
	}
	lcm_subscription_t *sub = lcm_subscribe(lcm, a.channel, record, &r);

	if (!sub) {
		fprintf(stderr, "omni4-record: cannot subscribe to '%s'\n", a.channel);
		close_log(&r);
		lcm_destroy(lcm);
		return 1;
	}
	lcm_subscription_set_queue_capacity(sub, RECORD_QUEUE_MESSAGES);

	struct sigaction sa = {.sa_handler = on_signal};

	sigemptyset(&sa.sa_mask);
	sigaction(SIGINT, &sa, NULL);
	sigaction(SIGTERM, &sa, NULL);
	signal(SIGPIPE, SIG_IGN); /* a FIFO's reader gone: EPIPE, reported, instead of death */
	record_until_stopped(lcm, &r, &a);
	/* What LCM already holds is written before the log is closed. */
	while (r.log && lcm_handle_timeout(lcm, 0) > 0)
		;
	lcm_unsubscribe(lcm, sub);
	lcm_destroy(lcm);
	close_log(&r);
	return report(&r, &a);
}
