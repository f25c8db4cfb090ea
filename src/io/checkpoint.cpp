// Checkpoint files (see checkpoint.hpp).
#include "io/checkpoint.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <xxhash.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "util/errors.hpp"
#include "util/hash.hpp"

namespace parode {
namespace {

const char* kMagic1 = "parode-checkpoint 1 ";
const char* kMagic = "parode-checkpoint 2 ";
constexpr std::size_t kFirstLine = 20 + 12 + 1 + 16 + 1;  // magic, head bytes, space, XXH3, newline
constexpr std::uint64_t kAlign = 4096;

std::uint64_t record_hash(const char* record, std::uint32_t gid) { return XXH3_64bits_withSeed(record, kRecordBytes, gid); }

std::uint64_t sum_blocks(std::uint64_t bodies) { return (bodies + kRecordSumBlock - 1) / kRecordSumBlock; }

[[noreturn]] void damaged(const std::string& path, const std::string& what) {
    throw CheckpointError(path + ": damaged checkpoint: " + what +
                          "; restart from an older one (the last one before it is kept as " + path + ".prev)");
}

void pack_record(const World& world, std::size_t i, char* out) {
    const BodyState s = world.state(i);
    const dReal* q = dBodyGetQuaternion(world.body(i));
    double v[21];
    v[20] = dBodyIsEnabled(world.body(i)) ? 1.0 : 0.0;
    std::copy(s.x, s.x + 3, v);
    std::copy(s.q, s.q + 4, v + 3);
    std::copy(q, q + 4, v + 7);
    std::copy(s.v, s.v + 3, v + 11);
    std::copy(s.w, s.w + 3, v + 14);
    std::copy(world.origin(i).begin(), world.origin(i).end(), v + 17);
    std::memcpy(out, v, kRecordBytes);
}

CheckpointRecord unpack_record(const char* in) {
    double v[21];
    std::memcpy(v, in, kRecordBytes);
    CheckpointRecord r;
    std::copy(v, v + 3, r.state.x);
    std::copy(v + 3, v + 7, r.state.q);
    std::copy(v + 7, v + 11, r.ode_q);
    std::copy(v + 11, v + 14, r.state.v);
    std::copy(v + 14, v + 17, r.state.w);
    std::copy(v + 17, v + 20, r.origin.begin());
    r.enabled = v[20] != 0.0;
    return r;
}

void pack_impulse(const WarmImpulse& m, char* out) {
    const std::uint32_t ids[3] = {m.lo, m.hi, m.index};
    std::memcpy(out, ids, sizeof ids);
    std::memcpy(out + sizeof ids, m.lambda, 3 * sizeof(double));
}

WarmImpulse unpack_impulse(const char* in) {
    WarmImpulse m;
    std::uint32_t ids[3];
    std::memcpy(ids, in, sizeof ids);
    m.lo = ids[0];
    m.hi = ids[1];
    m.index = ids[2];
    std::memcpy(m.lambda, in + sizeof ids, 3 * sizeof(double));
    return m;
}

// The first line (magic, head bytes, the XXH3 of the rest of the head),
// then the JSON padded with spaces to the head bytes.
std::vector<char> header(const nlohmann::json& meta, std::uint64_t& head_bytes) {
    std::string body = meta.dump() + "\n";
    head_bytes = (kFirstLine + body.size() + kAlign - 1) / kAlign * kAlign;
    body.resize(head_bytes - kFirstLine, ' ');
    char line[64];
    std::snprintf(line, sizeof line, "%s%012llu %s\n", kMagic, static_cast<unsigned long long>(head_bytes),
                  hex64(XXH3_64bits(body.data(), body.size())).c_str());
    const std::string h = std::string(line) + body;
    return std::vector<char>(h.begin(), h.end());
}

// Renames `tmp` over `path`, the FILE it replaces kept as FILE.prev: a hard
// link first, so that `path` names a complete checkpoint at every moment;
// then the folder synced, so that the rename survives a power loss.
void commit(const std::string& tmp, const std::string& path) {
    const std::string prev = path + ".prev";
    if (::access(path.c_str(), F_OK) == 0) {
        ::unlink(prev.c_str());
        if (::link(path.c_str(), prev.c_str()) != 0) ::rename(path.c_str(), prev.c_str());  // no hard links here
    }
    if (::rename(tmp.c_str(), path.c_str()) != 0) {
        throw OutputError(path + ": cannot rename " + tmp + " into place (" + std::strerror(errno) + ")");
    }
    const std::size_t slash = path.find_last_of('/');
    const std::string dir = slash == std::string::npos ? "." : slash == 0 ? "/" : path.substr(0, slash);
    const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        ::fsync(fd);
        ::close(fd);
    }
}

// Impulses per block of the index: blocks of at least 256, and about 65,536
// blocks in all, so the index stays small in the header at any size.
std::uint64_t index_block(std::int64_t impulses) {
    return std::max<std::uint64_t>(256, (static_cast<std::uint64_t>(impulses) + 65535) / 65536);
}

// This process's piece of the index: its impulse count, then the smallest
// and largest lower id of each block of `block` impulses.
std::vector<char> piece_index(const std::vector<WarmImpulse>* warm, std::uint64_t block, std::uint64_t hash) {
    std::vector<std::uint64_t> v{hash, warm ? warm->size() : 0};
    for (std::size_t b = 0; warm && b < warm->size(); b += block) {
        std::uint32_t lo = UINT32_MAX, hi = 0;
        for (std::size_t k = b; k < std::min<std::size_t>(warm->size(), b + block); ++k) {
            lo = std::min(lo, (*warm)[k].lo);
            hi = std::max(hi, (*warm)[k].lo);
        }
        v.push_back(lo);
        v.push_back(hi);
    }
    std::vector<char> out(v.size() * sizeof(std::uint64_t));
    std::memcpy(out.data(), v.data(), out.size());
    return out;
}

// Every process's piece, in file order, as the header's "impulse_index".
nlohmann::json impulse_index(const Collectives& domain, const std::vector<WarmImpulse>* warm, std::uint64_t block,
                             std::uint64_t hash) {
    nlohmann::json pieces = nlohmann::json::array();
    for (const std::vector<char>& bytes : domain.all_gather(piece_index(warm, block, hash))) {
        std::vector<std::uint64_t> v(bytes.size() / sizeof(std::uint64_t));
        std::memcpy(v.data(), bytes.data(), v.size() * sizeof(std::uint64_t));
        pieces.push_back({{"xxh3", hex64(v.at(0))}, {"count", v.at(1)},
                          {"lo", std::vector<std::uint64_t>(v.begin() + 2, v.end())}});
    }
    return {{"block", block}, {"pieces", pieces}};
}

// Throws std::runtime_error unless `index` describes `impulses` impulses in
// whole blocks, each with a lowest lower id no above its highest: a damaged
// index would make a reader skip impulses it needs.
void check_index(const nlohmann::json& index, std::uint64_t impulses) {
    const std::uint64_t block = index.at("block").get<std::uint64_t>();
    if (block == 0) throw std::runtime_error("impulse_index: block 0, expected at least 1");
    std::uint64_t total = 0;
    for (const nlohmann::json& piece : index.at("pieces")) {
        const std::uint64_t count = piece.at("count").get<std::uint64_t>();
        const std::vector<std::uint64_t> lo = piece.at("lo").get<std::vector<std::uint64_t>>();
        if (lo.size() != 2 * ((count + block - 1) / block)) {
            throw std::runtime_error("impulse_index: a piece of " + std::to_string(count) + " impulses lists " +
                                     std::to_string(lo.size() / 2) + " blocks of " + std::to_string(block) + ", expected " +
                                     std::to_string((count + block - 1) / block));
        }
        for (std::size_t b = 0; b < lo.size(); b += 2) {
            if (lo[b] > lo[b + 1]) throw std::runtime_error("impulse_index: a block's lowest id exceeds its highest");
        }
        total += count;
    }
    if (total != impulses) {
        throw std::runtime_error("impulse_index: " + std::to_string(total) + " impulses, expected " +
                                 std::to_string(impulses));
    }
}

}  // namespace

CheckpointCost& CheckpointCost::operator+=(const CheckpointCost& o) {
    written += o.written;
    seconds += o.seconds;
    checksum_seconds += o.checksum_seconds;
    bytes = o.bytes;
    return *this;
}

namespace {

// XXH3 of bytes handed in piece by piece.
class Xxh3Stream {
public:
    Xxh3Stream() : state_(XXH3_createState(), XXH3_freeState) { XXH3_64bits_reset(state_.get()); }
    void add(const char* data, std::size_t n) { XXH3_64bits_update(state_.get(), data, n); }
    std::uint64_t digest() const { return XXH3_64bits_digest(state_.get()); }
    std::string hex() const { return hex64(digest()); }

private:
    std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state_;
};

// XXH3 of the tail `f` will write (packed a piece at a time, as written).
std::uint64_t tail_xxh3(const FilePieces& f) {
    Xxh3Stream h;
    std::vector<char> piece(std::min(f.tail_count, f.piece) * f.tail_record);
    each_piece(f.tail_count, f.piece, [&](std::size_t first, std::size_t n) {
        f.pack_tail(first, n, piece.data());
        h.add(piece.data(), n * f.tail_record);
    });
    return h.digest();
}

// `use(piece)` for each piece of `extra` in order (collective).
template <class Use>
void each_piece(const SectionSource& extra, Use use) {
    std::vector<char> piece;
    for (std::size_t k = 0; k < extra.pieces(); ++k) {
        piece.clear();
        extra.piece(k, piece);
        use(piece);
    }
}

// The section's size and XXH3 for the head, from its pieces made on the
// writer (and sent to the others as text).
nlohmann::json section_sum(const Collectives& domain, const SectionSource& extra, std::uint64_t& bytes) {
    Xxh3Stream sum;
    std::uint64_t n = 0;
    each_piece(extra, [&](const std::vector<char>& piece) {
        sum.add(piece.data(), piece.size());
        n += piece.size();
    });
    const std::string mine = domain.last() && n > 0 ? std::to_string(n) + " " + sum.hex() : std::string();
    std::istringstream said(domain.all_text(mine, ""));
    std::string xxh3;
    if (!(said >> bytes >> xxh3)) return nullptr;
    return {{"bytes", bytes}, {"xxh3", xxh3}};
}

// The writer appends the section's pieces at `at` of the written file and
// syncs it; its error, if any (the others return none).
std::string append_section(const std::string& path, const Collectives& domain, const SectionSource& extra,
                           std::uint64_t at) {
    const bool writer = domain.last();
    const int fd = writer ? ::open(path.c_str(), O_WRONLY | O_CLOEXEC) : -1;
    bool ok = !writer || fd >= 0;
    int err = writer && fd < 0 ? errno : 0;
    each_piece(extra, [&](const std::vector<char>& piece) {  // every process takes part in every piece
        if (writer && ok && !write_at(fd, piece.data(), piece.size(), at)) ok = false, err = errno;
        at += piece.size();
    });
    if (writer && ok && ::fsync(fd) != 0) ok = false, err = errno;
    if (fd >= 0 && ::close(fd) != 0 && ok) ok = false, err = errno;
    return ok ? std::string() : path + ": writing the catom programs' state failed (" + std::strerror(err) + ")";
}

}  // namespace

CheckpointCost write_checkpoint(const std::string& path, const Collectives& domain, const World& world,
                                const std::vector<WarmImpulse>* warm, nlohmann::json meta,
                                const SectionSource* extra) {
    const auto start = std::chrono::steady_clock::now();
    FilePieces f;
    f.record = kRecordBytes;
    std::vector<std::pair<std::uint32_t, std::size_t>> owned;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (!world.ghost(i)) owned.emplace_back(world.gid(i), i);
    }
    std::sort(owned.begin(), owned.end());
    for (const auto& o : owned) f.gids.push_back(o.first);
    f.pack = [&world, &owned](std::size_t first, std::size_t n, char* out) {  // again as they are written
        for (std::size_t k = 0; k < n; ++k) pack_record(world, owned[first + k].second, out + k * kRecordBytes);
    };
    f.tail_record = kImpulseBytes;
    f.tail_count = warm ? warm->size() : 0;
    f.pack_tail = [warm](std::size_t first, std::size_t n, char* out) {
        for (std::size_t k = 0; k < n; ++k) pack_impulse((*warm)[first + k], out + k * kImpulseBytes);
    };
    const auto hashing = std::chrono::steady_clock::now();
    std::vector<std::uint64_t> sums(sum_blocks(world.global_body_count()), 0);
    for (std::size_t k = 0; k < owned.size(); ++k) {
        char record[kRecordBytes];
        pack_record(world, owned[k].second, record);
        sums[f.gids[k] / kRecordSumBlock] += record_hash(record, f.gids[k]);
    }
    const std::uint64_t tail_hash = tail_xxh3(f);
    double cost[2] = {std::chrono::duration<double>(std::chrono::steady_clock::now() - hashing).count(), 0};
    domain.sum_wrapping(sums.data(), static_cast<int>(sums.size()));  // every block's records, from every writer
    const std::int64_t impulses = domain.sum(static_cast<std::int64_t>(f.tail_count));
    meta["bodies"] = world.global_body_count();
    meta["impulses"] = impulses;
    meta["record_bytes"] = kRecordBytes;
    meta["impulse_bytes"] = kImpulseBytes;
    meta["impulse_index"] = impulse_index(domain, warm, index_block(impulses), tail_hash);
    meta["written_by_ranks"] = domain.ranks();
    std::vector<std::string> hex;
    for (std::uint64_t s : sums) hex.push_back(hex64(s));
    meta["checksums"] = {{"algorithm", "XXH3_64bits"}, {"record_block", kRecordSumBlock}, {"records", hex}};
    std::uint64_t extra_bytes = 0;
    if (extra) {
        nlohmann::json sum = section_sum(domain, *extra, extra_bytes);
        if (!sum.is_null()) meta["extra"] = std::move(sum);
    }
    std::uint64_t head_bytes = 0;
    const std::vector<char> head = header(meta, head_bytes);
    if (domain.root()) f.head = head;
    f.records_at = head_bytes;
    f.tail_at = head_bytes + world.global_body_count() * kRecordBytes;
    const std::string tmp = path + ".tmp";
    domain.write_file(tmp, f);  // collective: this process's part on the disk when it returns
    std::string failed = extra ? append_section(tmp, domain, *extra, f.tail_at + static_cast<std::uint64_t>(impulses) * kImpulseBytes)
                               : std::string();
    // Every process's part synced before the root renames; the writer's and
    // then the root's verdict shared, so that every process throws or none does.
    failed = domain.all_text(failed, "");  // also a barrier
    if (!failed.empty()) throw OutputError(failed);
    if (domain.root()) {
        try {
            commit(tmp, path);
        } catch (const OutputError& e) {
            failed = e.what();
        }
    }
    failed = domain.all_text(failed, "");
    if (!failed.empty()) throw OutputError(failed);
    cost[1] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    domain.max(cost, 2);
    return {1, cost[1], cost[0],
            f.tail_at + static_cast<std::uint64_t>(impulses) * kImpulseBytes + extra_bytes};
}

namespace {

// Version 2: the rest of the head read whole and its XXH3 checked against
// the first line's; `json` gets the head's JSON line.
void check_head(std::ifstream& in, const std::string& path, const std::string& line, Checkpoint& c, std::string& json) {
    if (line.size() + 1 != kFirstLine) damaged(path, "the first line is not '" + std::string(kMagic) + "<12 digits> <16 hex digits>'");
    c.head_bytes = std::stoull(line.substr(std::strlen(kMagic), 12));
    if (c.head_bytes <= kFirstLine || c.head_bytes > (std::uint64_t{1} << 36) || c.head_bytes % kAlign) {
        damaged(path, "the header's size " + std::to_string(c.head_bytes) + " is not a multiple of 4096");
    }
    std::string rest(c.head_bytes - kFirstLine, '\0');
    in.read(rest.data(), static_cast<std::streamsize>(rest.size()));
    if (!in) damaged(path, "the header ends before its " + std::to_string(c.head_bytes) + " bytes");
    const std::string want = line.substr(std::strlen(kMagic) + 13), got = hex64(XXH3_64bits(rest.data(), rest.size()));
    if (got != want) damaged(path, "header checksum " + got + ", written " + want);
    json = rest.substr(0, rest.find('\n'));
}

}  // namespace

Checkpoint read_checkpoint(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::invalid_argument(path + ": cannot open the checkpoint");
    std::string line;
    std::getline(in, line);
    Checkpoint c;
    c.path = path;
    c.version = line.rfind(kMagic, 0) == 0 ? 2 : line.rfind(kMagic1, 0) == 0 ? 1 : 0;
    if (c.version == 0) {  // another file, or a checkpoint whose first bytes were damaged
        throw CheckpointError(path + ": not a parode checkpoint, or a damaged one: its first line is '" +
                              line.substr(0, 40) + "', expected '" + std::string(kMagic) +
                              "<12 digits> <16 hex digits>'; if it is a damaged one, restart from an older one (the "
                              "last one before it is kept as " + path + ".prev)");
    }
    try {
        std::string json;
        if (c.version == 2) {
            check_head(in, path, line, c, json);
        } else {
            c.head_bytes = std::stoull(line.substr(std::strlen(kMagic1)));
            std::getline(in, json);
        }
        c.meta = nlohmann::json::parse(json);
        c.bodies = c.meta.at("bodies").get<std::uint64_t>();
        c.impulses = c.meta.at("impulses").get<std::uint64_t>();
        c.step = c.meta.at("step").get<long>();
        if (c.meta.contains("impulse_index")) check_index(c.meta.at("impulse_index"), c.impulses);
    } catch (const CheckpointError&) {
        throw;
    } catch (const std::exception& e) {
        damaged(path, std::string("its header cannot be read (") + e.what() + ")");
    }
    in.seekg(0, std::ios::end);
    const auto size = static_cast<std::uint64_t>(in.tellg());
    const std::uint64_t extra = c.meta.contains("extra") ? c.meta["extra"].value("bytes", std::uint64_t{0}) : 0;
    const std::uint64_t want = c.head_bytes + c.bodies * kRecordBytes + c.impulses * kImpulseBytes + extra;
    if (size != want) {
        damaged(path, "truncated or extended: " + std::to_string(size) + " bytes, expected " + std::to_string(want));
    }
    return c;
}

std::vector<CheckpointRecord> read_records(const Checkpoint& c, const std::vector<std::uint32_t>& gids,
                                           std::vector<std::uint64_t>* sums) {
    if (sums) sums->assign(sum_blocks(c.bodies), 0);
    constexpr std::size_t kRunRecords = 4096;  // records read at once, at most
    std::ifstream in(c.path, std::ios::binary);
    std::vector<CheckpointRecord> out;
    out.reserve(gids.size());
    std::vector<char> buf;
    for (std::size_t i = 0; i < gids.size();) {
        std::size_t j = i + 1;  // [i, j): consecutive ids, one read
        while (j < gids.size() && j - i < kRunRecords && gids[j] == gids[j - 1] + 1) ++j;
        buf.resize((j - i) * kRecordBytes);
        in.seekg(static_cast<std::streamoff>(c.head_bytes + std::uint64_t{gids[i]} * kRecordBytes));
        in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
        if (!in) {
            throw std::invalid_argument(c.path + ": cannot read the records of bodies " + std::to_string(gids[i]) + " to " +
                                        std::to_string(gids[j - 1]));
        }
        for (std::size_t k = 0; k < j - i; ++k) {
            const char* record = buf.data() + k * kRecordBytes;
            if (sums) (*sums)[gids[i + k] / kRecordSumBlock] += record_hash(record, gids[i + k]);
            out.push_back(unpack_record(record));
        }
        i = j;
    }
    return out;
}

std::vector<ImpulseRange> impulse_ranges(const nlohmann::json& index, const std::vector<std::uint32_t>& gids) {
    std::vector<ImpulseRange> out;
    const std::uint64_t block = index.at("block").get<std::uint64_t>();
    std::uint64_t first = 0;  // the piece's first impulse
    for (const nlohmann::json& piece : index.at("pieces")) {
        const std::uint64_t count = piece.at("count").get<std::uint64_t>();
        const std::vector<std::uint64_t> lo = piece.at("lo").get<std::vector<std::uint64_t>>();
        for (std::size_t b = 0; 2 * b + 1 < lo.size(); ++b) {
            const auto g = std::lower_bound(gids.begin(), gids.end(), lo[2 * b]);
            if (g == gids.end() || *g > lo[2 * b + 1]) continue;  // none of gids in the block's range
            const std::uint64_t at = first + b * block, n = std::min(block, count - b * block);
            if (!out.empty() && out.back().first + out.back().count == at) out.back().count += n;
            else out.push_back({at, n});
        }
        first += count;
    }
    return out;
}

namespace {

// Impulses [first, first + count) of the file whose lower body is in gids, appended to out.
void scan_impulses(std::ifstream& in, const Checkpoint& c, const ImpulseRange& r, const std::vector<std::uint32_t>& gids,
                   std::vector<WarmImpulse>& out) {
    in.seekg(static_cast<std::streamoff>(c.head_bytes + c.bodies * kRecordBytes + r.first * kImpulseBytes));
    std::vector<char> chunk(kImpulseBytes * 4096);
    for (std::uint64_t left = r.count; left > 0;) {
        const std::uint64_t n = std::min<std::uint64_t>(left, 4096);
        in.read(chunk.data(), static_cast<std::streamsize>(n * kImpulseBytes));
        if (!in) throw std::invalid_argument(c.path + ": cannot read the warm-start impulses");
        for (std::uint64_t k = 0; k < n; ++k) {
            const WarmImpulse m = unpack_impulse(chunk.data() + k * kImpulseBytes);
            if (std::binary_search(gids.begin(), gids.end(), m.lo)) out.push_back(m);
        }
        left -= n;
    }
}

}  // namespace

std::vector<WarmImpulse> read_impulses(const Checkpoint& c, const std::vector<std::uint32_t>& gids) {
    std::ifstream in(c.path, std::ios::binary);
    std::vector<WarmImpulse> out;
    const auto index = c.meta.find("impulse_index");
    const std::vector<ImpulseRange> ranges =
        index != c.meta.end() ? impulse_ranges(*index, gids) : std::vector<ImpulseRange>{{0, c.impulses}};
    for (const ImpulseRange& r : ranges) scan_impulses(in, c, r, gids, out);
    std::sort(out.begin(), out.end(), warm_less);
    return out;
}

namespace {

// Piece p of the impulses (from impulse `first`) read whole: "" when its
// XXH3 is the index's, else what differs.
std::string check_piece(const Checkpoint& c, const nlohmann::json& piece, std::uint64_t first, std::size_t p) {
    const std::uint64_t count = piece.at("count").get<std::uint64_t>();
    std::ifstream in(c.path, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(c.head_bytes + c.bodies * kRecordBytes + first * kImpulseBytes));
    XXH3_state_t* state = XXH3_createState();
    XXH3_64bits_reset(state);
    std::vector<char> chunk(std::size_t{1} << 20);
    for (std::uint64_t left = count * kImpulseBytes; left > 0 && in;) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, chunk.size()));
        in.read(chunk.data(), static_cast<std::streamsize>(n));
        XXH3_64bits_update(state, chunk.data(), n);
        left -= n;
    }
    const std::string got = hex64(XXH3_64bits_digest(state));
    XXH3_freeState(state);
    const std::string want = piece.value("xxh3", std::string("?"));
    if (in && got == want) return "";
    return "the impulses written by process " + std::to_string(p) + " (" + std::to_string(count) +
           "): checksum " + got + ", written " + want;
}

}  // namespace

nlohmann::json verify_checkpoint(const Checkpoint& c, std::vector<std::uint64_t> sums, const Collectives& domain) {
    if (c.version < 2) return {{"verified", false}, {"why", "a version 1 checkpoint carries no checksums"}};
    sums.resize(sum_blocks(c.bodies), 0);
    domain.sum_wrapping(sums.data(), static_cast<int>(sums.size()));  // every id read once, somewhere
    const nlohmann::json& want = c.meta.at("checksums").at("records");
    for (std::size_t b = 0; b < sums.size(); ++b) {
        const std::string w = b < want.size() ? want[b].get<std::string>() : "?";
        if (hex64(sums[b]) != w) {
            damaged(c.path, "the records of bodies " + std::to_string(b * kRecordSumBlock) + " to " +
                                std::to_string(std::min(c.bodies, (b + 1) * kRecordSumBlock) - 1) + ": checksum " +
                                hex64(sums[b]) + ", written " + w);
        }
    }
    const nlohmann::json& pieces = c.meta.at("impulse_index").at("pieces");
    std::string problem;
    std::uint64_t first = 0;
    for (std::size_t p = 0; p < pieces.size(); ++p) {
        if (static_cast<int>(p % static_cast<std::size_t>(domain.ranks())) == domain.rank() && problem.empty()) {
            problem = check_piece(c, pieces[p], first, p);
        }
        first += pieces[p].at("count").get<std::uint64_t>();
    }
    if (domain.sum(std::int64_t{problem.empty() ? 0 : 1}) > 0) damaged(c.path, domain.all_text(problem, "; "));
    return {{"verified", true}, {"algorithm", "XXH3_64bits"}, {"header", true}, {"record_blocks", sums.size()},
            {"impulse_pieces", pieces.size()}};
}

namespace {

// The checksum's reads, and the windows handed out (a record's length is
// known only once read, so a window is read past and refilled).
constexpr std::size_t kExtraRead = std::size_t{4} << 20, kExtraWindow = std::size_t{64} << 10;

std::uint64_t extra_at(const Checkpoint& c) { return c.head_bytes + c.bodies * kRecordBytes + c.impulses * kImpulseBytes; }

}  // namespace

ExtraReader::ExtraReader(const Checkpoint& c) : path_(c.path), in_(c.path, std::ios::binary) {
    if (!c.meta.contains("extra")) return;
    size_ = c.meta.at("extra").at("bytes").get<std::uint64_t>();
    in_.seekg(static_cast<std::streamoff>(extra_at(c)));
    Xxh3Stream sum;
    std::vector<char> window(kExtraRead);
    for (std::uint64_t left = size_; left > 0 && in_;) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, window.size()));
        in_.read(window.data(), static_cast<std::streamsize>(n));
        sum.add(window.data(), n);
        left -= n;
    }
    const std::string want = c.meta.at("extra").value("xxh3", std::string("?"));
    const std::string got = in_ ? sum.hex() : std::string("(truncated)");
    if (got != want) damaged(c.path, "the catom programs' state (" + std::to_string(size_) + " bytes): checksum " + got +
                                         ", written " + want);
    in_.seekg(static_cast<std::streamoff>(extra_at(c)));
    left_ = size_;
}

bool ExtraReader::refill(std::vector<char>& window, std::size_t& at) {
    window.erase(window.begin(), window.begin() + static_cast<std::ptrdiff_t>(at));
    at = 0;
    if (left_ == 0) return false;
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left_, kExtraWindow)), kept = window.size();
    window.resize(kept + n);
    in_.read(window.data() + kept, static_cast<std::streamsize>(n));
    if (!in_) throw CheckpointError(path_ + ": the catom programs' state could not be read again after its check");
    left_ -= n;
    return true;
}

}  // namespace parode
