/*
 * outfile.h - writing a file the user named, carefully (the INI save, omni4-record, the C++
 * host tools through host-tools/common/outfile.hpp).
 *
 * What is at the path decides how it is written:
 *  - nothing, or a regular file: written to PATH.tmpPID beside it, fsync'd, renamed over it,
 *    the directory fsync'd; a crash leaves the old or the new complete file; an existing
 *    file's permissions (and, where allowed, owner) are kept;
 *  - a symbolic link (to a file, or to nothing yet): the link is resolved and its TARGET is
 *    replaced as above, the link itself stays (a configuration kept in version control);
 *  - a character device, FIFO or socket: written in place (opened O_WRONLY, never created or
 *    truncated), every write and the close checked: /dev/full fails with ENOSPC;
 *  - a directory (or anything else): refused with EISDIR / EINVAL.
 * With OMNI4_OUT_STREAM (a log being recorded) a missing file is created and written where it
 * is (no temporary: what was written survives a crash), an existing regular file is refused
 * (EEXIST), a FIFO or device is written in place.
 * Every function returns 0 or a negative errno and, on error, one line in why naming the path.
 */
#ifndef OMNI4_OUTFILE_H
#define OMNI4_OUTFILE_H

#include <limits.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <sys/types.h>

#ifdef __cplusplus
extern "C" {
#endif

#define OMNI4_OUT_STREAM 1 /* write where it is; never over an existing regular file */

/* f is a stream over fd whose writes remember their errno: the struct must not move while f is
 * open. */
struct omni4_out {
	FILE *f;                 /* write through this; NULL once committed or aborted */
	int fd;                  /* under f */
	int write_errno;         /* the first failed write's errno (ENOSPC, EPIPE...), 0 if none */
	bool in_place;           /* a device, FIFO or socket (or OMNI4_OUT_STREAM) */
	bool existed;            /* target was there before (a regular file: it is replaced) */
	char path[PATH_MAX];     /* as named */
	char target[PATH_MAX];   /* the file written: path with symbolic links resolved */
	char tmp[PATH_MAX + 32]; /* the temporary beside target; "" when in place */
	mode_t mode;             /* the replaced file's permissions */
	uid_t uid;
	gid_t gid;
};

/* Opens path for writing as above; new_mode (less the umask) for a file that did not exist. */
int omni4_out_open(struct omni4_out *o, const char *path, mode_t new_mode, int flags, char *why,
                   size_t n);
/* path with its symbolic links followed (the file omni4_out_open writes): path itself when it
 * is no link. 0 or a negative errno. */
int omni4_out_resolve(const char *path, char *target, size_t n);
/* Whether omni4_out_open could write path, without opening it (a FIFO would wait for its
 * reader): before a long computation whose result goes there. 0, or a negative errno with why
 * (a directory, an existing file with OMNI4_OUT_STREAM, the folder missing or not writable). */
int omni4_out_check(const char *path, int flags, char *why, size_t n);
/* Flushes and closes (fsync for a file), renames the temporary over the target and fsyncs its
 * directory. On any error nothing is replaced and the temporary is removed. */
int omni4_out_commit(struct omni4_out *o, char *why, size_t n);
/* Closes and removes the temporary (the target untouched); safe after commit or a failed open. */
void omni4_out_abort(struct omni4_out *o);

#ifdef __cplusplus
}
#endif

#endif /* OMNI4_OUTFILE_H */
