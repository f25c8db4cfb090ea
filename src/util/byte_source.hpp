// Bytes handed out in order, a window at a time: what a reader of a long
// section needs (a checkpoint's catom-program state, io/checkpoint.hpp),
// without the layer that reads it knowing files.
// Trade-off: the reader refills when a record runs past the window's end
// and reads it again (a record's length is known only once read), instead
// of knowing record lengths up front.
#pragma once
#include <cstddef>
#include <vector>

namespace parode {

class ByteSource {
public:
    virtual ~ByteSource() = default;
    // Drops window[0, at) and appends the next unread bytes; at becomes 0.
    // False when none were left to append.
    virtual bool refill(std::vector<char>& window, std::size_t& at) = 0;
};

}  // namespace parode
