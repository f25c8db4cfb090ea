// Exact fixed-point summation of doubles (see exact_sum.hpp).
#include "util/exact_sum.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace parode {
namespace {

constexpr int kBias = 1152;                  // bit 0 of digit 0 weighs 2^-1152
constexpr std::int64_t kLow = 0xFFFFFFFFLL;  // one digit
constexpr std::int64_t kNormaliseEvery = std::int64_t{1} << 30;

int leading_zeros32(std::uint64_t w) {  // w in (0, 2^32)
    int n = 0;
    for (std::uint64_t bit = std::uint64_t{1} << 31; !(w & bit); bit >>= 1) ++n;
    return n;
}

// The 96-bit magnitude w0 w1 w2 (32-bit digits, w0 != 0) times 2^e, rounded
// to nearest even, with `sticky` set when nonzero bits lie below w2.
double round_digits(std::uint64_t w0, std::uint64_t w1, std::uint64_t w2, bool sticky, int e) {
    const int s = 32 - leading_zeros32(w0);  // significant bits of w0: the top 64 bits are A >> s
    const std::uint64_t m = (w0 << (64 - s)) | (w1 << (32 - s)) | (w2 >> s);
    sticky = sticky || (w2 & ((std::uint64_t{1} << s) - 1)) != 0;
    std::uint64_t mant = m >> 11;
    const std::uint64_t rest = m & 0x7FF;
    const bool up = rest > 0x400 || (rest == 0x400 && (sticky || (mant & 1)));
    if (up) ++mant;
    return std::ldexp(static_cast<double>(mant), e + s + 11);
}

}  // namespace

void ExactSum::add(double x) {
    std::uint64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    const int exp = static_cast<int>((bits >> 52) & 0x7FF);
    const std::uint64_t frac = bits & ((std::uint64_t{1} << 52) - 1);
    const bool negative = (bits >> 63) != 0;
    if (exp == 0x7FF) {
        if (frac) ++nan_;
        else if (negative) ++ninf_;
        else ++pinf_;
        return;
    }
    const std::uint64_t mant = exp ? frac | (std::uint64_t{1} << 52) : frac;
    if (mant == 0) return;
    const int p = (exp ? exp - 1075 : -1074) + kBias;  // bit position of the mantissa's lowest bit
    const int b = p >> 5, r = p & 31;
    const auto lo = static_cast<std::int64_t>((mant << r) & kLow);
    const auto mid = static_cast<std::int64_t>((mant >> (32 - r)) & kLow);
    const auto hi = static_cast<std::int64_t>(r ? mant >> (64 - r) : 0);
    // Negated without a branch ((v ^ -1) + 1 = -v): signs of momenta are a
    // coin toss from one body to the next, and a mispredicted branch costs
    // more than the whole addition.
    const std::int64_t neg = -static_cast<std::int64_t>(negative);
    d_[b] += (lo ^ neg) - neg;
    d_[b + 1] += (mid ^ neg) - neg;
    d_[b + 2] += (hi ^ neg) - neg;
    if (++adds_ >= kNormaliseEvery) normalise();
}

void ExactSum::merge(const ExactSum& o) {
    for (int i = 0; i < kDigits; ++i) d_[i] += o.d_[i];
    nan_ += o.nan_;
    pinf_ += o.pinf_;
    ninf_ += o.ninf_;
    adds_ += o.adds_ + 1;
    if (adds_ >= kNormaliseEvery) normalise();
}

void ExactSum::normalise() {
    for (int i = 0; i + 1 < kDigits; ++i) {
        const std::int64_t low = d_[i] & kLow;
        d_[i + 1] += (d_[i] - low) / (kLow + 1);
        d_[i] = low;
    }
    adds_ = 0;
}

double ExactSum::value() const {
    if (nan_ || (pinf_ && ninf_)) return std::numeric_limits<double>::quiet_NaN();
    if (pinf_) return HUGE_VAL;
    if (ninf_) return -HUGE_VAL;
    ExactSum m = *this;
    m.normalise();
    const bool negative = m.d_[kDigits - 1] < 0;
    if (negative) {
        for (std::int64_t& x : m.d_) x = -x;
        m.normalise();
    }
    int t = kDigits - 1;
    while (t >= 0 && m.d_[t] == 0) --t;
    if (t < 0) return 0.0;
    if (m.d_[t] > kLow) return negative ? -HUGE_VAL : HUGE_VAL;  // past 2^1088
    bool sticky = false;
    for (int i = 0; i < t - 2; ++i) sticky = sticky || m.d_[i] != 0;
    auto digit = [&m](int i) { return i >= 0 ? static_cast<std::uint64_t>(m.d_[i]) : 0; };
    const double v = round_digits(digit(t), digit(t - 1), digit(t - 2), sticky, 32 * (t - 2) - kBias);
    return negative ? -v : v;
}

}  // namespace parode
