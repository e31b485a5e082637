// SPDX-License-Identifier: GPL-3.0-or-later
#include "bus_crypto.h"

#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/kdf.h>
#include <openssl/params.h>
#include <openssl/rand.h>

#include <algorithm>
#include <cstring>
#include <memory>
#include <stdexcept>

namespace hemo {

namespace {
constexpr std::size_t kGcmNonce = 12, kGcmTag = 16, kMark = 8, kTag = 32;

struct CipherCtx {
  EVP_CIPHER_CTX* p = EVP_CIPHER_CTX_new();
  ~CipherCtx() { EVP_CIPHER_CTX_free(p); }
};
}  // namespace

Bytes random_bytes(std::size_t n) {
  Bytes b(n);
  if (RAND_bytes(b.data(), static_cast<int>(n)) != 1) throw std::runtime_error("OpenSSL has no random numbers");
  return b;
}

Bytes derive_key(const Bytes& secret, const std::string& purpose, std::size_t len) {
  std::unique_ptr<EVP_KDF, decltype(&EVP_KDF_free)> kdf(EVP_KDF_fetch(nullptr, "HKDF", nullptr), EVP_KDF_free);
  std::unique_ptr<EVP_KDF_CTX, decltype(&EVP_KDF_CTX_free)> ctx(kdf ? EVP_KDF_CTX_new(kdf.get()) : nullptr,
                                                                EVP_KDF_CTX_free);
  char digest[] = "SHA256";
  std::string info = purpose;
  Bytes key_in = secret;
  OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string(OSSL_KDF_PARAM_DIGEST, digest, 0),
                         OSSL_PARAM_construct_octet_string(OSSL_KDF_PARAM_KEY, key_in.data(), key_in.size()),
                         OSSL_PARAM_construct_octet_string(OSSL_KDF_PARAM_INFO, info.data(), info.size()),
                         OSSL_PARAM_construct_end()};
  Bytes out(len);
  if (!ctx || EVP_KDF_derive(ctx.get(), out.data(), out.size(), params) != 1)
    throw std::runtime_error("HKDF-SHA256 unavailable from OpenSSL");
  return out;
}

Digest hmac_sha256(const Bytes& key, const Bytes& data) {
  Digest d{};
  if (EVP_Q_mac(nullptr, "HMAC", nullptr, "SHA256", nullptr, key.data(), key.size(), data.data(), data.size(), d.data(),
                d.size(), nullptr) == nullptr)
    throw std::runtime_error("HMAC-SHA256 unavailable from OpenSSL");
  return d;
}

bool same_digest(const std::uint8_t* a, const std::uint8_t* b) { return CRYPTO_memcmp(a, b, kTag) == 0; }

// ---- handshake ----

Bytes handshake_key(const Bytes& secret) { return derive_key(secret, "hemocosim relay handshake v1"); }

namespace {
Digest both_nonces(const Bytes& key, const char* who, const Bytes& relay_nonce, const Bytes& client_nonce) {
  Bytes m(who, who + std::strlen(who));
  m.insert(m.end(), relay_nonce.begin(), relay_nonce.end());
  m.insert(m.end(), client_nonce.begin(), client_nonce.end());
  return hmac_sha256(key, m);
}
}  // namespace

Bytes handshake_answer(const Bytes& key, const Bytes& relay_nonce, const Bytes& client_nonce) {
  const auto mac = both_nonces(key, "client", relay_nonce, client_nonce);
  Bytes a(1 + client_nonce.size() + mac.size());
  a[0] = kAuthAnswer;
  std::copy(client_nonce.begin(), client_nonce.end(), a.begin() + 1);
  std::copy(mac.begin(), mac.end(), a.begin() + 1 + static_cast<std::ptrdiff_t>(client_nonce.size()));
  return a;
}

Bytes handshake_proof(const Bytes& key, const Bytes& relay_nonce, const Bytes& client_nonce) {
  const auto mac = both_nonces(key, "relay", relay_nonce, client_nonce);
  Bytes p(1 + mac.size());
  p[0] = kAuthAccepted;
  std::copy(mac.begin(), mac.end(), p.begin() + 1);
  return p;
}

std::optional<Bytes> check_handshake_answer(const Bytes& key, const Bytes& relay_nonce, const std::uint8_t* answer,
                                            std::size_t len) {
  if (len != 1 + kNonceBytes + kTag || answer[0] != kAuthAnswer) return std::nullopt;
  Bytes client_nonce(answer + 1, answer + 1 + kNonceBytes);
  const auto mac = both_nonces(key, "client", relay_nonce, client_nonce);
  if (!same_digest(mac.data(), answer + 1 + kNonceBytes)) return std::nullopt;
  return client_nonce;
}

// ---- sealed messages ----

Bytes seal_key(const Bytes& secret) { return derive_key(secret, "hemocosim bus payload AES-256-GCM v1"); }

bool is_sealed(const std::uint8_t* buf, std::size_t len) {
  return len >= kMark && std::equal(kSealedMark.begin(), kSealedMark.end(), buf);
}

// The envelope but its tag (filled in after sealing) is the GCM's associated data: a ciphertext
// moved under another envelope does not open.
Bytes seal(const Bytes& key, const std::uint8_t* plain, std::size_t len, std::size_t body_offset) {
  if (body_offset < kMark + kTag || body_offset > len) throw std::runtime_error("seal: no envelope");
  Bytes out(len + kSealOverhead);
  std::copy(kSealedMark.begin(), kSealedMark.end(), out.begin());
  std::copy(plain + kMark, plain + body_offset, out.begin() + kMark);
  std::uint8_t* nonce = out.data() + body_offset;
  if (RAND_bytes(nonce, kGcmNonce) != 1) throw std::runtime_error("OpenSSL has no random numbers");
  std::uint8_t* ct = nonce + kGcmNonce;
  CipherCtx c;
  int n = 0, m = 0;
  const bool ok =
      c.p && EVP_EncryptInit_ex(c.p, EVP_aes_256_gcm(), nullptr, key.data(), nonce) == 1 &&
      EVP_EncryptUpdate(c.p, nullptr, &n, plain + kMark, static_cast<int>(body_offset - kMark - kTag)) == 1 &&
      EVP_EncryptUpdate(c.p, ct, &n, plain, static_cast<int>(kMark)) == 1 &&
      EVP_EncryptUpdate(c.p, ct + n, &m, plain + body_offset, static_cast<int>(len - body_offset)) == 1 &&
      EVP_EncryptFinal_ex(c.p, ct + n + m, &n) == 1 &&
      EVP_CIPHER_CTX_ctrl(c.p, EVP_CTRL_GCM_GET_TAG, kGcmTag, out.data() + out.size() - kGcmTag) == 1;
  if (!ok) throw std::runtime_error("AES-256-GCM unavailable from OpenSSL");
  return out;
}

std::optional<Bytes> unseal(const Bytes& key, const std::uint8_t* sealed, std::size_t len, std::size_t body_offset) {
  if (!is_sealed(sealed, len) || body_offset < kMark + kTag || len < body_offset + kSealOverhead) return std::nullopt;
  const std::uint8_t* nonce = sealed + body_offset;
  const std::uint8_t* ct = nonce + kGcmNonce;
  const std::size_t ct_len = len - body_offset - kGcmNonce - kGcmTag;  // fingerprint + payload
  Bytes fingerprint(kMark);
  Bytes out(len - kSealOverhead);
  std::copy(sealed + kMark, sealed + body_offset, out.begin() + kMark);
  CipherCtx c;
  int n = 0;
  std::uint8_t tag[kGcmTag];
  std::memcpy(tag, sealed + len - kGcmTag, kGcmTag);
  const bool ok =
      c.p && EVP_DecryptInit_ex(c.p, EVP_aes_256_gcm(), nullptr, key.data(), nonce) == 1 &&
      EVP_DecryptUpdate(c.p, nullptr, &n, sealed + kMark, static_cast<int>(body_offset - kMark - kTag)) == 1 &&
      EVP_DecryptUpdate(c.p, fingerprint.data(), &n, ct, static_cast<int>(kMark)) == 1 &&
      EVP_DecryptUpdate(c.p, out.data() + body_offset, &n, ct + kMark, static_cast<int>(ct_len - kMark)) == 1 &&
      EVP_CIPHER_CTX_ctrl(c.p, EVP_CTRL_GCM_SET_TAG, kGcmTag, tag) == 1 &&
      EVP_DecryptFinal_ex(c.p, out.data() + out.size(), &n) == 1;
  if (!ok) return std::nullopt;
  std::copy(fingerprint.begin(), fingerprint.end(), out.begin());
  return out;
}

}  // namespace hemo
