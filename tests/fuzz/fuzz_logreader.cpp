// libFuzzer target: bytes -> event log file -> omni4-ident's log reader -> segments ->
// identification. Properties: no crash/UB/leak; bad input ends in a counted skip or an
// IdentError / runtime_error, never anything else.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "identify.hpp"
#include "logdata.hpp"
#include "validate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	const int fd = memfd_create("omni4-fuzz-log", 0);
	if (fd < 0)
		return 0;
	if (size && write(fd, data, size) != static_cast<ssize_t>(size)) {
		close(fd);
		return 0;
	}
	const std::string path = "/proc/self/fd/" + std::to_string(fd);
	try {
		const omni4::LogData d = omni4::read_log(path);
		if (d.bytes_skipped > d.bytes_total)
			__builtin_trap();
		const auto segs = omni4::split_segments(d);
		try {
			omni4::identify(segs, model_params_table3);
		} catch (const omni4::IdentError &) {
		}
		try {
			omni4::validate(segs, model_params_table3);
		} catch (const omni4::IdentError &) {
		}
	} catch (const std::runtime_error &) {
	}
	close(fd);
	return 0;
}
