#include "odocal/records/digest.h"

#include <openssl/evp.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <memory>

namespace odocal::records {
namespace {

class Sha256 {
 public:
  Sha256() : ctx_(EVP_MD_CTX_new(), &EVP_MD_CTX_free) { EVP_DigestInit_ex(ctx_.get(), EVP_sha256(), nullptr); }
  void Add(const void* data, size_t size) { EVP_DigestUpdate(ctx_.get(), data, size); }
  void Add(const std::string& text) {
    // Length first: ("ab", "c") and ("a", "bc") digest differently.
    const unsigned long long n = text.size();
    Add(&n, sizeof(n));
    Add(text.data(), text.size());
  }
  std::string HexDigest() {
    std::array<unsigned char, EVP_MAX_MD_SIZE> out{};
    unsigned int size = 0;
    EVP_DigestFinal_ex(ctx_.get(), out.data(), &size);
    static constexpr char kHex[] = "0123456789abcdef";
    std::string hex;
    for (unsigned int i = 0; i < size; ++i) {
      hex += kHex[out[i] >> 4];
      hex += kHex[out[i] & 15];
    }
    return hex;
  }

 private:
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx_;
};

}  // namespace

Result<std::string> DigestFiles(const std::string& label, const std::vector<std::string>& files) {
  Sha256 sha;
  sha.Add(label);
  std::vector<char> buffer(1 << 20);
  for (const std::string& file : files) {
    std::ifstream in(file, std::ios::binary);
    if (!in) return Result<std::string>::Error(StatusCode::kNotFound, file + ": cannot be read for the run's digest");
    sha.Add(std::filesystem::path(file).filename().string());
    while (in) {
      in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
      sha.Add(buffer.data(), static_cast<size_t>(in.gcount()));
    }
    if (in.bad()) return Result<std::string>::Error(StatusCode::kIoError, file + ": read failed for the run's digest");
  }
  return Result<std::string>::Ok(sha.HexDigest());
}

std::string DigestText(const std::string& text) {
  Sha256 sha;
  sha.Add(text.data(), text.size());
  return sha.HexDigest();
}

}  // namespace odocal::records
