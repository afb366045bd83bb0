/*
 * Tests for the careful writer (config/src/outfile.c) through the parameter service's save
 * (config_save), per kind of target: a symbolic link (kept, its target replaced, .bak beside the
 * target), a full device (ENOSPC, the node kept), a null device and a FIFO (written in place, the
 * reader gets the file), a directory (refused), and the streaming mode of omni4-record (never
 * over an existing file). Device nodes are made with mknod in the test's own folder.
 */
#include "omni4_test.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include "omni4/config/config.h"
#include "omni4/config/outfile.h"

static char g_dir[64];
static char g_path[160], g_why[600];

static void make_dir(void)
{
	snprintf(g_dir, sizeof(g_dir), "/tmp/omni4-outfile-XXXXXX");
	assert_non_null(mkdtemp(g_dir));
}

static void remove_dir(void)
{
	char cmd[128];

	snprintf(cmd, sizeof(cmd), "rm -rf '%s'", g_dir);
	assert_int_equal(system(cmd), 0);
}

static const char *in_dir(const char *name)
{
	snprintf(g_path, sizeof(g_path), "%s/%s", g_dir, name);
	return g_path;
}

static void write_text(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");

	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

static double saved_kp(const char *path)
{
	struct omni4_config back;
	struct config_error err;

	config_defaults(&back);
	assert_int_equal(config_load(path, &back, &err), 0);
	return back.ctl.control.kp;
}

static void config_with_kp(struct omni4_config *c, double kp)
{
	config_defaults(c);
	c->ctl.control.kp = kp;
}

/* Entries of the test's folder (a temporary or .bak left behind shows here). */
static int count_entries(void)
{
	DIR *d = opendir(g_dir);
	int n = 0;

	assert_non_null(d);
	for (struct dirent *e; (e = readdir(d));)
		n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
	closedir(d);
	return n;
}

static void test_save_through_a_symlink_replaces_the_target_and_keeps_the_link(void **state)
{
	(void)state;
	char link[160], real[160], bak[170], text[64];
	struct omni4_config c;
	struct stat st;

	make_dir();
	snprintf(real, sizeof(real), "%s", in_dir("configs"));
	assert_int_equal(mkdir(real, 0755), 0);
	snprintf(real, sizeof(real), "%s", in_dir("configs/robot.ini"));
	snprintf(bak, sizeof(bak), "%s.bak", real);
	snprintf(link, sizeof(link), "%s", in_dir("robot.ini"));
	write_text(real, "[control]\nkp = 3\n");
	assert_int_equal(chmod(real, 0600), 0);
	assert_int_equal(symlink("configs/robot.ini", link), 0); /* relative, as in a checkout */
	config_with_kp(&c, 42.5);
	assert_int_equal(config_save(link, &c, "saved", g_why, sizeof(g_why)), 0);
	assert_non_null(strstr(g_why, "previous kept as "));
	assert_non_null(strstr(g_why, "configs/robot.ini.bak"));
	assert_int_equal(lstat(link, &st), 0);
	assert_true(S_ISLNK(st.st_mode));
	const ssize_t n = readlink(link, text, sizeof(text) - 1);

	assert_true(n > 0);
	text[n] = '\0';
	assert_string_equal(text, "configs/robot.ini");
	assert_near(saved_kp(real), 42.5, 0);
	assert_near(saved_kp(bak), 3.0, 0);
	assert_int_equal(stat(real, &st), 0);
	assert_int_equal(st.st_mode & 0777, 0600);
	assert_int_equal(count_entries(), 2); /* the link and configs/: no .bak or temporary here */
	char resolved[PATH_MAX];

	assert_int_equal(omni4_out_resolve(link, resolved, sizeof(resolved)), 0);
	assert_non_null(strstr(resolved, "configs/robot.ini"));
	remove_dir();
}

static void test_save_to_a_full_device_fails_with_enospc_and_keeps_the_node(void **state)
{
	(void)state;
	struct omni4_config c;
	struct stat st;
	char full[160];

	make_dir();
	snprintf(full, sizeof(full), "%s", in_dir("full"));
	assert_int_equal(mknod(full, S_IFCHR | 0666, makedev(1, 7)), 0);
	config_with_kp(&c, 7.0);
	assert_int_equal(config_save(full, &c, NULL, g_why, sizeof(g_why)), -ENOSPC);
	assert_non_null(strstr(g_why, full));
	assert_non_null(strstr(g_why, "No space left on device"));
	assert_null(strchr(g_why, '\n'));
	assert_int_equal(lstat(full, &st), 0);
	assert_true(S_ISCHR(st.st_mode));
	assert_int_equal(st.st_rdev, makedev(1, 7));
	assert_int_equal(count_entries(), 1); /* no temporary, no .bak */
	remove_dir();
}

static void test_save_to_a_null_device_writes_in_place(void **state)
{
	(void)state;
	struct omni4_config c;
	struct stat st;
	char null[160];

	make_dir();
	snprintf(null, sizeof(null), "%s", in_dir("null"));
	assert_int_equal(mknod(null, S_IFCHR | 0666, makedev(1, 3)), 0);
	config_with_kp(&c, 7.0);
	assert_int_equal(config_save(null, &c, NULL, g_why, sizeof(g_why)), 0);
	assert_string_equal(g_why, "written in place (not a regular file): no .bak");
	assert_int_equal(lstat(null, &st), 0);
	assert_true(S_ISCHR(st.st_mode));
	assert_int_equal(count_entries(), 1);
	remove_dir();
}

/* A reader of the FIFO in a child process: copies what comes to out, exits 0 at end of file. */
static pid_t start_reader(const char *fifo, const char *out)
{
	const pid_t pid = fork();

	assert_true(pid >= 0);
	if (pid)
		return pid;
	alarm(5); /* a writer that never comes (the FIFO replaced): fails, never hangs */
	const int in = open(fifo, O_RDONLY);
	const int to = open(out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
	char buf[4096];
	ssize_t got;

	if (in < 0 || to < 0)
		_exit(2);
	while ((got = read(in, buf, sizeof(buf))) > 0)
		if (write(to, buf, (size_t)got) != got)
			_exit(3);
	_exit(got == 0 && close(to) == 0 ? 0 : 4);
}

static void test_save_to_a_fifo_gives_the_reader_the_file(void **state)
{
	(void)state;
	struct omni4_config c;
	struct stat st;
	char fifo[160], out[160];
	int status;

	make_dir();
	snprintf(fifo, sizeof(fifo), "%s", in_dir("robot.fifo"));
	snprintf(out, sizeof(out), "%s", in_dir("received.ini"));
	assert_int_equal(mkfifo(fifo, 0644), 0);
	const pid_t reader = start_reader(fifo, out);

	config_with_kp(&c, 12.25);
	assert_int_equal(config_save(fifo, &c, "to a reader", g_why, sizeof(g_why)), 0);
	assert_string_equal(g_why, "written in place (not a regular file): no .bak");
	assert_int_equal(waitpid(reader, &status, 0), reader);
	assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
	assert_near(saved_kp(out), 12.25, 0);
	assert_int_equal(lstat(fifo, &st), 0);
	assert_true(S_ISFIFO(st.st_mode));
	assert_int_equal(count_entries(), 2); /* the FIFO and what the reader wrote */
	remove_dir();
}

static void test_save_to_a_directory_is_refused(void **state)
{
	(void)state;
	struct omni4_config c;
	struct stat st;
	char d[160];

	make_dir();
	snprintf(d, sizeof(d), "%s", in_dir("robot.ini"));
	assert_int_equal(mkdir(d, 0755), 0);
	config_with_kp(&c, 7.0);
	assert_int_equal(config_save(d, &c, NULL, g_why, sizeof(g_why)), -EISDIR);
	assert_non_null(strstr(g_why, d));
	assert_int_equal(stat(d, &st), 0);
	assert_true(S_ISDIR(st.st_mode));
	assert_int_equal(count_entries(), 1);
	assert_int_equal(omni4_out_check(d, 0, g_why, sizeof(g_why)), -EISDIR);
	remove_dir();
}

static void test_stream_never_writes_over_a_file_and_writes_a_new_one_in_place(void **state)
{
	(void)state;
	struct omni4_out o;
	char old[160], fresh[160], text[16] = {0};

	make_dir();
	snprintf(old, sizeof(old), "%s", in_dir("old.lcmlog"));
	snprintf(fresh, sizeof(fresh), "%s", in_dir("new.lcmlog"));
	write_text(old, "keep");
	assert_int_equal(omni4_out_open(&o, old, 0666, OMNI4_OUT_STREAM, g_why, sizeof(g_why)),
	                 -EEXIST);
	assert_non_null(strstr(g_why, "exists; not overwriting it"));
	assert_int_equal(omni4_out_check(old, OMNI4_OUT_STREAM, g_why, sizeof(g_why)), -EEXIST);
	assert_int_equal(omni4_out_open(&o, fresh, 0666, OMNI4_OUT_STREAM, g_why, sizeof(g_why)),
	                 0);
	assert_true(o.in_place);
	assert_string_equal(o.tmp, "");
	fputs("log", o.f);
	assert_int_equal(omni4_out_commit(&o, g_why, sizeof(g_why)), 0);
	FILE *f = fopen(fresh, "r");

	assert_non_null(f);
	assert_non_null(fgets(text, sizeof(text), f));
	fclose(f);
	assert_string_equal(text, "log");
	f = fopen(old, "r");
	assert_non_null(fgets(text, sizeof(text), f));
	fclose(f);
	assert_string_equal(text, "keep");
	remove_dir();
}

static void test_a_link_to_a_missing_file_creates_the_target(void **state)
{
	(void)state;
	struct omni4_out o;
	struct stat st;
	char link[160];

	make_dir();
	snprintf(link, sizeof(link), "%s", in_dir("out.ini"));
	assert_int_equal(symlink("later.ini", link), 0);
	assert_int_equal(omni4_out_open(&o, link, 0666, 0, g_why, sizeof(g_why)), 0);
	fputs("[model]\n", o.f);
	assert_int_equal(omni4_out_commit(&o, g_why, sizeof(g_why)), 0);
	assert_int_equal(lstat(link, &st), 0);
	assert_true(S_ISLNK(st.st_mode));
	assert_int_equal(stat(in_dir("later.ini"), &st), 0);
	assert_true(S_ISREG(st.st_mode) && st.st_size == 8);
	remove_dir();
}

int main(void)
{
	const struct CMUnitTest tests[] = {
	    cmocka_unit_test(test_save_through_a_symlink_replaces_the_target_and_keeps_the_link),
	    cmocka_unit_test(test_save_to_a_full_device_fails_with_enospc_and_keeps_the_node),
	    cmocka_unit_test(test_save_to_a_null_device_writes_in_place),
	    cmocka_unit_test(test_save_to_a_fifo_gives_the_reader_the_file),
	    cmocka_unit_test(test_save_to_a_directory_is_refused),
	    cmocka_unit_test(test_stream_never_writes_over_a_file_and_writes_a_new_one_in_place),
	    cmocka_unit_test(test_a_link_to_a_missing_file_creates_the_target),
	};

	signal(SIGPIPE, SIG_IGN);
	return cmocka_run_group_tests(tests, NULL, NULL);
}
