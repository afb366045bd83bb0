// median.hpp - the exact median of a series of integers (sample intervals in us) without a
// copy of the series: a histogram around the first value, a sorted copy only for a series
// that spreads wider than the histogram.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace omni4
{

// The element of rank count / 2 (0-based) in sorted order: what std::nth_element leaves at
// begin + size / 2. each(visit) must call visit(v) once per value, the same values every call
// (it is called up to three times). Returns false for an empty series.
template <class Each> bool median_int64(Each each, int64_t &out)
{
	constexpr int64_t kHalf = 2048;
	std::vector<uint32_t> hist(2 * kHalf);
	int64_t base = 0;
	size_t count = 0, outside = 0;
	each([&](int64_t v) {
		if (count++ == 0)
			base = v - kHalf;
		const uint64_t bin = static_cast<uint64_t>(v) - static_cast<uint64_t>(base);
		if (bin < hist.size())
			++hist[bin];
		else
			++outside;
	});
	if (count == 0)
		return false;
	if (outside == 0) {
		size_t below = 0;
		for (size_t b = 0; b < hist.size(); ++b) {
			below += hist[b];
			if (below > count / 2) {
				out = base + static_cast<int64_t>(b);
				return true;
			}
		}
	}
	std::vector<int64_t> all;
	all.reserve(count);
	each([&](int64_t v) { all.push_back(v); });
	std::nth_element(all.begin(), all.begin() + all.size() / 2, all.end());
	out = all[all.size() / 2];
	return true;
}

} // namespace omni4
