// testlog.hpp - temporary file names and LCM event logs written event by event (lcm/eventlog.h),
// for the host tests that build logs by hand.
#pragma once

#include <lcm/eventlog.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace omni4_test
{

// A fresh name in /tmp ending in tag (the file itself is not created).
inline std::string temp_path(const char *tag)
{
	char buf[] = "/tmp/omni4_test_XXXXXX";
	const int fd = mkstemp(buf);
	if (fd >= 0)
		close(fd);
	std::remove(buf);
	return std::string(buf) + tag;
}

// An event log being written; put() and put_bytes() return false on any failure.
class EventLogWriter
{
      public:
	explicit EventLogWriter(const std::string &path)
	    : log_(lcm_eventlog_create(path.c_str(), "w"))
	{
	}
	~EventLogWriter()
	{
		close();
	}
	EventLogWriter(const EventLogWriter &) = delete;
	EventLogWriter &operator=(const EventLogWriter &) = delete;
	bool ok() const
	{
		return log_ != nullptr;
	}
	void close()
	{
		if (log_)
			lcm_eventlog_destroy(log_);
		log_ = nullptr;
	}
	// An lcm-gen message, encoded.
	template <typename T> static std::vector<uint8_t> encode(const T &msg)
	{
		std::vector<uint8_t> buf(static_cast<size_t>(msg.getEncodedSize()));
		if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) !=
		    static_cast<int>(buf.size()))
			buf.clear();
		return buf;
	}
	template <typename T> bool put(const char *channel, const T &msg)
	{
		const std::vector<uint8_t> buf = encode(msg);
		return !buf.empty() && put_bytes(channel, buf);
	}
	bool put_bytes(const char *channel, std::vector<uint8_t> buf)
	{
		if (!log_)
			return false;
		lcm_eventlog_event_t ev{};
		ev.eventnum = event_++;
		ev.timestamp = 1000 * event_;
		ev.channellen = static_cast<int32_t>(std::strlen(channel));
		ev.channel = const_cast<char *>(channel);
		ev.datalen = static_cast<int32_t>(buf.size());
		ev.data = buf.data();
		return lcm_eventlog_write_event(log_, &ev) == 0;
	}

      private:
	lcm_eventlog_t *log_;
	int64_t event_ = 0;
};

} // namespace omni4_test
