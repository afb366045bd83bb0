// Tests for the event log reader (logdata.hpp): motors_t samples read in place give the values
// lcm-gen's encoder wrote, bit for bit, and a motors_t event that lcm-gen's decoder would not
// take in full (wrong fingerprint, a byte short or over) is counted undecodable.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "logdata.hpp"
#include "omni4/motors_t.hpp"
#include "testlog.hpp"

using namespace omni4;

namespace
{

uint32_t bits(float x)
{
	uint32_t b;
	std::memcpy(&b, &x, sizeof b);
	return b;
}

// A finite float of any sign and exponent (subnormals and -0 included), from random bits.
float any_finite(std::mt19937_64 &rng)
{
	for (;;) {
		const uint32_t b = static_cast<uint32_t>(rng());
		float x;
		std::memcpy(&x, &b, sizeof x);
		if (std::isfinite(x))
			return x;
	}
}

} // namespace

TEST(ReadLog, MotorsSamplesHoldTheWrittenValuesBitForBit)
{
	const std::string path = omni4_test::temp_path(".lcmlog");
	omni4_test::EventLogWriter log(path);
	ASSERT_TRUE(log.ok());
	std::mt19937_64 rng(11);
	std::vector<motors_t> sent;
	for (int64_t k = 0; k < 500; ++k) {
		motors_t m{};
		m.utime = 1000000 + 997 * k + static_cast<int64_t>(rng() % 3);
		m.seq = k * 3 + (int64_t{1} << 40);
		m.mode = static_cast<int8_t>(rng());
		m.faults = static_cast<int32_t>(rng());
		for (int j = 0; j < 4; ++j) {
			m.voltage[j] = any_finite(rng);
			m.current[j] = any_finite(rng);
			m.wheel_speed[j] = any_finite(rng);
		}
		sent.push_back(m);
		ASSERT_TRUE(log.put("OMNI4_MOTORS", m));
	}
	std::vector<uint8_t> buf = omni4_test::EventLogWriter::encode(sent[0]);
	buf.push_back(0); // a byte over
	ASSERT_TRUE(log.put_bytes("OMNI4_MOTORS", buf));
	buf.resize(buf.size() - 2); // a byte short
	ASSERT_TRUE(log.put_bytes("OMNI4_MOTORS", buf));
	buf = omni4_test::EventLogWriter::encode(sent[0]);
	buf[3] ^= 0x10; // another fingerprint
	ASSERT_TRUE(log.put_bytes("OMNI4_MOTORS", buf));
	log.close();

	const LogData d = read_log(path);
	std::remove(path.c_str());
	EXPECT_EQ(d.undecodable, 3u);
	EXPECT_EQ(d.implausible, 0u);
	ASSERT_EQ(d.motors.size(), sent.size());
	for (size_t k = 0; k < sent.size(); ++k) {
		const MotorsSample &s = d.motors[k];
		const motors_t &m = sent[k];
		ASSERT_EQ(s.utime, m.utime) << k;
		ASSERT_EQ(s.seq, m.seq) << k;
		ASSERT_EQ(s.mode, m.mode) << k;
		ASSERT_EQ(s.faults, m.faults) << k;
		for (int j = 0; j < 4; ++j) {
			ASSERT_EQ(bits(s.u[j]), bits(m.voltage[j])) << k << " " << j;
			ASSERT_EQ(bits(s.i[j]), bits(m.current[j])) << k << " " << j;
			ASSERT_EQ(bits(s.w[j]), bits(m.wheel_speed[j])) << k << " " << j;
		}
	}
}
