// outfile.hpp - a file the user named (--out, --json, a --csv folder's files), written by what
// is there: a regular or missing file through a temporary beside it and a rename, a symbolic
// link's target (the link kept), a device or FIFO in place with every write checked, a
// directory refused. The rules are omni4/outfile.h's (config/), shared with the C tools.
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>

#include "omni4/config/outfile.h"

// One line naming the path: "PATH: No space left on device".
struct OutError : std::runtime_error {
	using std::runtime_error::runtime_error;
};

// An output being written; nothing replaced until commit(). Destroyed uncommitted, it removes
// its temporary and leaves the target as it was.
class OutFile
{
      public:
	explicit OutFile(const std::string &path, int flags = 0);
	~OutFile();
	OutFile(const OutFile &) = delete;
	OutFile &operator=(const OutFile &) = delete;

	FILE *file() const
	{
		return out_.f;
	}
	// Written where it is (a device or FIFO), not replaced.
	bool in_place() const
	{
		return out_.in_place;
	}
	// Where a writer that opens by name writes: the temporary, or the device or FIFO itself.
	const char *write_path() const
	{
		return out_.tmp[0] ? out_.tmp : out_.target;
	}
	void write(const std::string &text);
	void commit();

      private:
	omni4_out out_{};
};

// The whole of text into path (OutFile); throws OutError.
void write_file(const std::string &path, const std::string &text);
// Throws OutError if path could not be written (checked before a long computation).
void check_out(const std::string &path, int flags = 0);
