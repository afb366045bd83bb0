/* config_save.c - the INI writer (every key of the table, with its doc and unit) and the
 * crash-safe replacement of a robot's INI file (omni4/outfile.h), the previous file kept. */
#include "omni4/config/config.h"
#include "config_table.h"

#include "omni4/config/outfile.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int config_write_model(FILE *f, const struct model_params *p)
{
	if (fprintf(f, "[model]\n") < 0)
		return -EIO;
	for (int i = 0; i < MODEL_PARAMS_COUNT; i++) {
		char v[40];

		if (config_format_double(v, sizeof(v), model_params_get(p, i)) < 0 ||
		    fprintf(f, "%s = %s\n", model_params_names[i], v) < 0)
			return -EIO;
	}
	return 0;
}

/* true if a key before i has k's section: the section was written with that key's. */
static bool section_written(size_t i)
{
	for (size_t j = 0; j < i; j++)
		if (!strcmp(config_keys[j].section, config_keys[i].section))
			return true;
	return false;
}

/* Every key of section i's, in table order, under one [section] line. */
static int write_section(FILE *f, const struct omni4_config *cfg, size_t i)
{
	char value[256];

	if (fprintf(f, "%s[%s]\n", i ? "\n" : "", config_keys[i].section) < 0)
		return -EIO;
	for (size_t j = i; j < config_n_keys; j++) {
		const struct config_key *k = &config_keys[j];

		/* a wheel without its own key: it takes the scalar on reading */
		if (strcmp(k->section, config_keys[i].section) ||
		    (config_wheel_bit(k) && !(cfg->ctl.wheel_keys & config_wheel_bit(k))) ||
		    (config_dist_bit(k) && !(cfg->ctl.layout_keys & config_dist_bit(k))))
			continue;
		if (config_key_format(cfg, (int)j, value, sizeof(value)))
			return -EINVAL;
		if (fprintf(f, "; %s%s%s%s\n%s = %s\n", k->doc, k->unit[0] ? " [" : "", k->unit,
		            k->unit[0] ? "]" : "", k->name, value) < 0)
			return -EIO;
	}
	return 0;
}

int config_write(FILE *f, const struct omni4_config *cfg, const char *header)
{
	if (header && fprintf(f, "; %s\n", header) < 0)
		return -EIO;
	for (size_t i = 0; i < config_n_keys; i++) {
		const int rc = section_written(i) ? 0 : write_section(f, cfg, i);

		if (rc)
			return rc;
	}
	return fflush(f) ? -EIO : 0;
}

/* Copy src to dst through dst.tmp (fsync, rename): for file systems without hard links. */
static int copy_file(const char *src, const char *dst)
{
	char tmp[PATH_MAX + 16];
	char buf[4096];
	int rc = 0;

	if ((size_t)snprintf(tmp, sizeof(tmp), "%s.tmp", dst) >= sizeof(tmp))
		return -ENAMETOOLONG;
	FILE *in = fopen(src, "rb");

	if (!in)
		return -errno;
	FILE *out = fopen(tmp, "wb");

	if (!out) {
		rc = -errno;
		fclose(in);
		return rc;
	}
	for (size_t got; (got = fread(buf, 1, sizeof(buf), in)) > 0;)
		if (fwrite(buf, 1, got, out) != got) {
			rc = -EIO;
			break;
		}
	if (!rc && (ferror(in) || fflush(out) || fsync(fileno(out))))
		rc = -EIO;
	fclose(in);
	if (fclose(out) && !rc)
		rc = -EIO;
	if (!rc && rename(tmp, dst))
		rc = -errno;
	if (rc)
		unlink(tmp);
	return rc;
}

/* The file about to be replaced becomes target.bak (a hard link: the file itself never goes
 * away), beside the file itself when the INI is reached through a symbolic link. */
static int keep_previous(const struct omni4_out *o, char *why, size_t n)
{
	char bak[PATH_MAX + 8];
	int rc;

	if (o->in_place || !o->existed)
		return 0;
	if ((size_t)snprintf(bak, sizeof(bak), "%s.bak", o->target) >= sizeof(bak)) {
		snprintf(why, n, "%s: path too long", o->path);
		return -ENAMETOOLONG;
	}
	if (unlink(bak) && errno != ENOENT) {
		rc = -errno;
		snprintf(why, n, "%s: cannot replace: %s", bak, strerror(-rc));
		return rc;
	}
	if (link(o->target, bak) && errno != ENOENT && (rc = copy_file(o->target, bak))) {
		snprintf(why, n, "%s: cannot keep the previous file: %s", bak, strerror(-rc));
		return rc;
	}
	return 0;
}

int config_save(const char *path, const struct omni4_config *cfg, const char *header, char *why,
                size_t n)
{
	struct omni4_out o;
	int rc = omni4_out_open(&o, path, 0644, 0, why, n);

	if (rc)
		return rc;
	rc = config_write(o.f, cfg, header);
	if (rc == -EINVAL) {
		snprintf(why, n, "a string value cannot be written to an INI file unchanged");
		omni4_out_abort(&o);
		return rc;
	}
	/* -EIO: the commit below finds the stream's error and says which */
	if (!rc && (rc = keep_previous(&o, why, n))) {
		omni4_out_abort(&o);
		return rc;
	}
	const bool in_place = o.in_place, existed = o.existed;
	char bak[PATH_MAX + 8];

	snprintf(bak, sizeof(bak), "%s.bak", o.target);
	rc = omni4_out_commit(&o, why, n);
	if (!rc && in_place)
		snprintf(why, n, "written in place (not a regular file): no .bak");
	else if (!rc && existed)
		snprintf(why, n, "previous kept as %s", bak);
	else if (!rc)
		snprintf(why, n, "a new file: no previous one to keep");
	return rc;
}
