// Generates src/marker/dictionaries.rs: OpenCV's predefined ArUco dictionaries as bit tables.
//
// Build and run (from the repository root):
//   g++ -O1 -o /tmp/gen_aruco tools/gen_aruco_dictionaries.cpp $(pkg-config --cflags --libs opencv4)
//   /tmp/gen_aruco > src/marker/dictionaries.rs && rustfmt --edition 2021 src/marker/dictionaries.rs
//
// Only the largest dictionary of each family is emitted: the program verifies that the _50, _100
// and _250 variants are exact prefixes of the _1000 one (same codes, same order, same marker
// size) and aborts otherwise, so the Rust side may slice the _1000 table.
#include <opencv2/aruco.hpp>
#include <opencv2/core.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace {

// One marker's bits, row-major, first cell in the most significant of the n*n used bits;
// 1 = white cell (OpenCV's convention in getBitsFromByteList / drawMarker).
uint64_t packed_bits(const cv::Ptr<cv::aruco::Dictionary>& dict, int id) {
    const int n = dict->markerSize;
    cv::Mat bits = cv::aruco::Dictionary::getBitsFromByteList(dict->bytesList.rowRange(id, id + 1), n);
    uint64_t word = 0;
    for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) {
            word = (word << 1) | (bits.at<unsigned char>(r, c) ? 1u : 0u);
        }
    }
    return word;
}

std::vector<uint64_t> table(int name) {
    cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(name);
    std::vector<uint64_t> out;
    for (int id = 0; id < dict->bytesList.rows; ++id) out.push_back(packed_bits(dict, id));
    return out;
}

int marker_size(int name) { return cv::aruco::getPredefinedDictionary(name)->markerSize; }

void emit(const char* rust_name, int name, const std::vector<int>& prefixes) {
    const std::vector<uint64_t> full = table(name);
    const int n = marker_size(name);
    for (int p : prefixes) {
        const std::vector<uint64_t> part = table(p);
        if (marker_size(p) != n || part.size() > full.size()) {
            std::fprintf(stderr, "dictionary %d is not a prefix of %s\n", p, rust_name);
            std::exit(1);
        }
        for (size_t i = 0; i < part.size(); ++i) {
            if (part[i] != full[i]) {
                std::fprintf(stderr, "dictionary %d differs from %s at id %zu\n", p, rust_name, i);
                std::exit(1);
            }
        }
    }
    std::printf("/// OpenCV `%s`: %zu markers of %dx%d bits (see the module doc for the packing).\n",
                rust_name, full.size(), n, n);
    std::printf("pub static %s: [u64; %zu] = [\n", rust_name, full.size());
    for (uint64_t w : full) std::printf("    0x%016llx,\n", static_cast<unsigned long long>(w));
    std::printf("];\n\n");
}

}  // namespace

int main() {
    namespace A = cv::aruco;
    std::printf(
        "//! GENERATED FILE, do not edit: OpenCV %s predefined ArUco dictionaries as bit tables.\n"
        "//!\n"
        "//! Regenerate from the repository root with\n"
        "//! `g++ -O1 -o /tmp/gen_aruco tools/gen_aruco_dictionaries.cpp $(pkg-config --cflags --libs opencv4)`\n"
        "//! then `/tmp/gen_aruco > src/marker/dictionaries.rs && rustfmt --edition 2021 src/marker/dictionaries.rs`.\n"
        "//!\n"
        "//! Packing: one `u64` per marker id; the n×n data bits (border excluded) are row-major, the\n"
        "//! top-left cell in bit n·n − 1 (most significant used bit), the bottom-right cell in bit 0.\n"
        "//! A set bit is a WHITE cell (OpenCV's convention: getBitsFromByteList / drawMarker).\n"
        "//! The generator verified that OpenCV's _50, _100 and _250 dictionaries are exact prefixes\n"
        "//! of the _1000 one, so only the _1000 tables are stored.\n\n",
        CV_VERSION);
    emit("DICT_4X4_1000", A::DICT_4X4_1000, {A::DICT_4X4_50, A::DICT_4X4_100, A::DICT_4X4_250});
    emit("DICT_5X5_1000", A::DICT_5X5_1000, {A::DICT_5X5_50, A::DICT_5X5_100, A::DICT_5X5_250});
    emit("DICT_6X6_1000", A::DICT_6X6_1000, {A::DICT_6X6_50, A::DICT_6X6_100, A::DICT_6X6_250});
    emit("DICT_7X7_1000", A::DICT_7X7_1000, {A::DICT_7X7_50, A::DICT_7X7_100, A::DICT_7X7_250});
    emit("DICT_ARUCO_ORIGINAL", A::DICT_ARUCO_ORIGINAL, {});
    return 0;
}
