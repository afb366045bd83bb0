// outfile.cpp - OutFile over omni4_out (config/src/outfile.c).
#include "outfile.hpp"

OutFile::OutFile(const std::string &path, int flags)
{
	char why[PATH_MAX + 200];
	if (omni4_out_open(&out_, path.c_str(), 0666, flags, why, sizeof(why)))
		throw OutError(why);
}

OutFile::~OutFile()
{
	omni4_out_abort(&out_);
}

void OutFile::write(const std::string &text)
{
	// an error is kept by the stream and reported by commit() with its errno
	if (out_.f)
		std::fwrite(text.data(), 1, text.size(), out_.f);
}

void OutFile::commit()
{
	char why[PATH_MAX + 200];
	if (omni4_out_commit(&out_, why, sizeof(why)))
		throw OutError(why);
}

void write_file(const std::string &path, const std::string &text)
{
	OutFile f(path);
	f.write(text);
	f.commit();
}

void check_out(const std::string &path, int flags)
{
	char why[PATH_MAX + 200];
	if (omni4_out_check(path.c_str(), flags, why, sizeof(why)))
		throw OutError(why);
}
