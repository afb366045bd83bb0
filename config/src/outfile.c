/* outfile.c - a file the user named, written by what is there: replaced through a temporary,
 * through a symbolic link, or in place (a device or FIFO); see omni4/outfile.h. */
#include "omni4/config/outfile.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define OUT_MAX_LINKS 40 /* as the kernel's ELOOP limit */

static int fail(char *why, size_t n, const char *path, const char *what, int rc)
{
	snprintf(why, n, "%s: %s%s", path, what, strerror(-rc));
	return rc;
}

static int refuse_existing(char *why, size_t n, const char *path)
{
	snprintf(why, n, "%s exists; not overwriting it", path);
	return -EEXIST;
}

/* The directory part of path ("." for none). */
static void dir_of(const char *path, char *dir, size_t n)
{
	const char *slash = strrchr(path, '/');

	if (!slash)
		snprintf(dir, n, ".");
	else if (slash == path)
		snprintf(dir, n, "/");
	else
		snprintf(dir, n, "%.*s", (int)(slash - path), path);
}

static int sync_dir_of(const char *path)
{
	char dir[PATH_MAX];

	dir_of(path, dir, sizeof(dir));
	const int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);

	if (fd < 0)
		return -errno;
	const int rc = fsync(fd) ? -errno : 0;

	close(fd);
	return rc;
}

/* target, reached through a link: its canonical name when it exists (no ".." left). */
static int resolved(char *target, size_t n, bool through_link)
{
	char real[PATH_MAX];

	if (through_link && realpath(target, real) && strlen(real) < n)
		snprintf(target, n, "%s", real);
	return 0;
}

/* path with its symbolic links followed (also to a file that does not exist yet) into
 * target. A relative link is read from the link's own directory, as the kernel does. */
static int resolve_links(const char *path, char *target, size_t n)
{
	char link[PATH_MAX], dir[PATH_MAX];
	struct stat st;

	snprintf(target, n, "%s", path);
	for (int i = 0; i < OUT_MAX_LINKS; i++) {
		if (lstat(target, &st))
			return errno == ENOENT ? 0 : -errno;
		if (!S_ISLNK(st.st_mode))
			return resolved(target, n, i > 0);
		const ssize_t len = readlink(target, link, sizeof(link) - 1);

		if (len < 0)
			return -errno;
		link[len] = '\0';
		dir_of(target, dir, sizeof(dir));
		if (link[0] == '/' ? (size_t)snprintf(target, n, "%s", link) >= n
		                   : (size_t)snprintf(target, n, "%s/%s", dir, link) >= n)
			return -ENAMETOOLONG;
	}
	return -ELOOP;
}

int omni4_out_resolve(const char *path, char *target, size_t n)
{
	return resolve_links(path, target, n);
}

/* stdio's writes to fd, keeping the first error's errno (stdio itself keeps only a flag). */
static ssize_t cookie_write(void *cookie, const char *buf, size_t n)
{
	struct omni4_out *o = cookie;
	size_t done = 0;

	while (done < n) {
		const ssize_t w = write(o->fd, buf + done, n - done);

		if (w < 0 && errno == EINTR)
			continue;
		if (w <= 0) {
			if (!o->write_errno)
				o->write_errno = w < 0 ? errno : EIO;
			return (ssize_t)done; /* short: stdio marks the stream failed */
		}
		done += (size_t)w;
	}
	return (ssize_t)n;
}

static int cookie_close(void *cookie)
{
	struct omni4_out *o = cookie;
	const int rc = close(o->fd);

	if (rc && !o->write_errno)
		o->write_errno = errno;
	o->fd = -1;
	return rc;
}

static int open_fd(struct omni4_out *o, int fd, char *why, size_t n)
{
	static const cookie_io_functions_t io = {.write = cookie_write, .close = cookie_close};

	o->fd = fd;
	o->f = fopencookie(o, "w", io);
	if (!o->f) {
		const int rc = -errno;

		close(fd);
		if (o->tmp[0])
			unlink(o->tmp);
		return fail(why, n, o->path, "", rc);
	}
	return 0;
}

static int open_temporary(struct omni4_out *o, mode_t new_mode, char *why, size_t n)
{
	const int flags = O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC;
	const mode_t mode = o->existed ? 0600 : new_mode; /* the umask applies to a new file */
	char what[PATH_MAX + 64];

	if ((size_t)snprintf(o->tmp, sizeof(o->tmp), "%s.tmp%ld", o->target, (long)getpid()) >=
	    sizeof(o->tmp))
		return fail(why, n, o->path, "", -ENAMETOOLONG);
	int fd = open(o->tmp, flags, mode);

	if (fd < 0 && errno == EEXIST && !unlink(o->tmp)) /* left by a crash */
		fd = open(o->tmp, flags, mode);
	if (fd < 0) {
		const int rc = -errno;

		snprintf(what, sizeof(what), "cannot create %s: ", o->tmp);
		o->tmp[0] = '\0';
		return fail(why, n, o->path, what, rc);
	}
	return open_fd(o, fd, why, n);
}

/* A device, FIFO or socket (or a stream's new file): opened where it is. */
static int open_in_place(struct omni4_out *o, int extra, mode_t new_mode, char *why, size_t n)
{
	const int fd = open(o->target, O_WRONLY | O_NOCTTY | O_CLOEXEC | extra, new_mode);

	o->in_place = true;
	if (fd < 0)
		return fail(why, n, o->path, "", -errno);
	return open_fd(o, fd, why, n);
}

int omni4_out_open(struct omni4_out *o, const char *path, mode_t new_mode, int flags, char *why,
                   size_t n)
{
	struct stat st;

	memset(o, 0, sizeof(*o));
	o->fd = -1;
	if ((size_t)snprintf(o->path, sizeof(o->path), "%s", path) >= sizeof(o->path))
		return fail(why, n, path, "", -ENAMETOOLONG);
	const int rc = resolve_links(path, o->target, sizeof(o->target));

	if (rc)
		return fail(why, n, path, "", rc);
	if (stat(o->target, &st)) {
		if (errno != ENOENT)
			return fail(why, n, path, "", -errno);
		if (flags & OMNI4_OUT_STREAM)
			return open_in_place(o, O_CREAT | O_EXCL, new_mode, why, n);
		return open_temporary(o, new_mode, why, n);
	}
	o->existed = true;
	if (S_ISREG(st.st_mode)) {
		if (flags & OMNI4_OUT_STREAM)
			return refuse_existing(why, n, path);
		o->mode = st.st_mode & 07777;
		o->uid = st.st_uid;
		o->gid = st.st_gid;
		return open_temporary(o, new_mode, why, n);
	}
	if (S_ISDIR(st.st_mode))
		return fail(why, n, path, "", -EISDIR);
	if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode) ||
	    S_ISBLK(st.st_mode))
		return open_in_place(o, 0, 0, why, n);
	return fail(why, n, path, "not a file, device or FIFO: ", -EINVAL);
}

int omni4_out_check(const char *path, int flags, char *why, size_t n)
{
	char target[PATH_MAX], dir[PATH_MAX];
	struct stat st;
	const int rc = resolve_links(path, target, sizeof(target));

	if (rc)
		return fail(why, n, path, "", rc);
	if (!stat(target, &st)) {
		if (S_ISDIR(st.st_mode))
			return fail(why, n, path, "", -EISDIR);
		if (!S_ISREG(st.st_mode))
			return 0; /* written in place (or refused by open with the reason) */
		if (flags & OMNI4_OUT_STREAM)
			return refuse_existing(why, n, path);
	} else if (errno != ENOENT) {
		return fail(why, n, path, "", -errno);
	}
	dir_of(target, dir, sizeof(dir));
	if (stat(dir, &st)) {
		snprintf(why, n, "%s: %s: %s", path, dir, strerror(errno));
		return -ENOENT;
	}
	if (!S_ISDIR(st.st_mode)) {
		snprintf(why, n, "%s: %s is not a folder", path, dir);
		return -ENOTDIR;
	}
	if (access(dir, W_OK)) {
		snprintf(why, n, "%s: cannot write in %s: %s", path, dir, strerror(errno));
		return -EACCES;
	}
	return 0;
}

/* Everything written reaches the file (the permissions of the one replaced, fsync), closed. */
static int flush_and_close(struct omni4_out *o)
{
	struct stat st;
	int rc = 0;

	if (fflush(o->f) || ferror(o->f))
		rc = -(o->write_errno ? o->write_errno : EIO);
	if (!rc && o->tmp[0] && o->existed) {
		if (fchown(o->fd, o->uid, o->gid)) /* only where allowed */
			errno = 0;
		if (fchmod(o->fd, o->mode))
			rc = -errno;
	}
	if (!rc && !fstat(o->fd, &st) && S_ISREG(st.st_mode) && fsync(o->fd))
		rc = -errno;
	if (fclose(o->f) && !rc)
		rc = -(o->write_errno ? o->write_errno : EIO);
	o->f = NULL;
	return rc;
}

int omni4_out_commit(struct omni4_out *o, char *why, size_t n)
{
	if (!o->f)
		return fail(why, n, o->path, "", -EBADF);
	int rc = flush_and_close(o);

	if (rc) {
		omni4_out_abort(o);
		return fail(why, n, o->path, "", rc);
	}
	if (!o->tmp[0])
		return 0;
	if (rename(o->tmp, o->target)) {
		rc = -errno;
		omni4_out_abort(o);
		return fail(why, n, o->path, "cannot replace: ", rc);
	}
	o->tmp[0] = '\0';
	rc = sync_dir_of(o->target);
	return rc ? fail(why, n, o->path, "directory sync failed: ", rc) : 0;
}

void omni4_out_abort(struct omni4_out *o)
{
	if (o->f)
		fclose(o->f);
	o->f = NULL;
	if (o->tmp[0])
		unlink(o->tmp);
	o->tmp[0] = '\0';
}
