// Checkpoint files (see checkpoint.hpp).
#include "io/checkpoint.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace parode {
namespace {

const char* kMagic = "parode-checkpoint 1 ";
constexpr std::uint64_t kAlign = 4096;

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

void pack_impulse(const WarmImpulse& m, std::vector<char>& out) {
    const std::size_t at = out.size();
    out.resize(at + kImpulseBytes);
    const std::uint32_t ids[3] = {m.lo, m.hi, m.index};
    std::memcpy(out.data() + at, ids, sizeof ids);
    std::memcpy(out.data() + at + sizeof ids, m.lambda, 3 * sizeof(double));
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

std::vector<char> header(const nlohmann::json& meta, std::uint64_t& head_bytes) {
    const std::string body = meta.dump() + "\n";
    const std::size_t first = std::strlen(kMagic) + 13;  // magic, 12 digits, newline
    head_bytes = (first + body.size() + kAlign - 1) / kAlign * kAlign;
    char line[64];
    std::snprintf(line, sizeof line, "%s%012llu\n", kMagic, static_cast<unsigned long long>(head_bytes));
    std::string h = std::string(line) + body;
    h.resize(head_bytes, ' ');
    return std::vector<char>(h.begin(), h.end());
}

// Impulses per block of the index: blocks of at least 256, and about 65,536
// blocks in all, so the index stays small in the header at any size.
std::uint64_t index_block(std::int64_t impulses) {
    return std::max<std::uint64_t>(256, (static_cast<std::uint64_t>(impulses) + 65535) / 65536);
}

// This process's piece of the index: its impulse count, then the smallest
// and largest lower id of each block of `block` impulses.
std::vector<char> piece_index(const std::vector<WarmImpulse>* warm, std::uint64_t block) {
    std::vector<std::uint64_t> v{warm ? warm->size() : 0};
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
nlohmann::json impulse_index(const Collectives& domain, const std::vector<WarmImpulse>* warm, std::uint64_t block) {
    nlohmann::json pieces = nlohmann::json::array();
    for (const std::vector<char>& bytes : domain.all_gather(piece_index(warm, block))) {
        std::vector<std::uint64_t> v(bytes.size() / sizeof(std::uint64_t));
        std::memcpy(v.data(), bytes.data(), v.size() * sizeof(std::uint64_t));
        pieces.push_back({{"count", v.at(0)}, {"lo", std::vector<std::uint64_t>(v.begin() + 1, v.end())}});
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

void write_checkpoint(const std::string& path, const Collectives& domain, const World& world,
                      const std::vector<WarmImpulse>* warm, nlohmann::json meta) {
    FilePieces f;
    f.record = kRecordBytes;
    std::vector<std::pair<std::uint32_t, std::size_t>> owned;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (!world.ghost(i)) owned.emplace_back(world.gid(i), i);
    }
    std::sort(owned.begin(), owned.end());
    f.records.resize(owned.size() * kRecordBytes);
    for (std::size_t k = 0; k < owned.size(); ++k) {
        f.gids.push_back(owned[k].first);
        pack_record(world, owned[k].second, f.records.data() + k * kRecordBytes);
    }
    if (warm) {
        for (const WarmImpulse& m : *warm) pack_impulse(m, f.tail);
    }
    const std::int64_t impulses = domain.sum(static_cast<std::int64_t>(f.tail.size() / kImpulseBytes));
    meta["bodies"] = world.global_body_count();
    meta["impulses"] = impulses;
    meta["record_bytes"] = kRecordBytes;
    meta["impulse_bytes"] = kImpulseBytes;
    meta["impulse_index"] = impulse_index(domain, warm, index_block(impulses));
    meta["written_by_ranks"] = domain.ranks();
    std::uint64_t head_bytes = 0;
    const std::vector<char> head = header(meta, head_bytes);
    if (domain.root()) f.head = head;
    f.records_at = head_bytes;
    f.tail_at = head_bytes + world.global_body_count() * kRecordBytes;
    domain.write_file(path, f);
}

Checkpoint read_checkpoint(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::invalid_argument(path + ": cannot open the checkpoint");
    std::string line;
    std::getline(in, line);
    if (line.rfind(kMagic, 0) != 0) throw std::invalid_argument(path + ": not a parode checkpoint (no '" + std::string(kMagic) + "' line)");
    Checkpoint c;
    c.path = path;
    try {
        c.head_bytes = std::stoull(line.substr(std::strlen(kMagic)));
        std::string json;
        std::getline(in, json);
        c.meta = nlohmann::json::parse(json);
        c.bodies = c.meta.at("bodies").get<std::uint64_t>();
        c.impulses = c.meta.at("impulses").get<std::uint64_t>();
        c.step = c.meta.at("step").get<long>();
        if (c.meta.contains("impulse_index")) check_index(c.meta.at("impulse_index"), c.impulses);
    } catch (const std::exception& e) {
        throw std::invalid_argument(path + ": damaged checkpoint header (" + e.what() + ")");
    }
    in.seekg(0, std::ios::end);
    const auto size = static_cast<std::uint64_t>(in.tellg());
    const std::uint64_t want = c.head_bytes + c.bodies * kRecordBytes + c.impulses * kImpulseBytes;
    if (size != want) {
        throw std::invalid_argument(path + ": truncated or damaged checkpoint (" + std::to_string(size) + " bytes, expected " +
                                 std::to_string(want) + ")");
    }
    return c;
}

std::vector<CheckpointRecord> read_records(const Checkpoint& c, const std::vector<std::uint32_t>& gids) {
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
        for (std::size_t k = 0; k < j - i; ++k) out.push_back(unpack_record(buf.data() + k * kRecordBytes));
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

}  // namespace parode
