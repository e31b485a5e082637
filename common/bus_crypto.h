// The cryptography of the bus beyond each message's HMAC (bus.h): keys derived from the run's
// secret, the TCP relay's challenge-response handshake, and the optional encryption of message
// payloads (bus.encrypt; docs/hosts.md, "What an observer of the network learns"). OpenSSL does
// the work; this names what each key is for, so that no key serves two purposes.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace hemo {

using Bytes = std::vector<std::uint8_t>;
using Digest = std::array<std::uint8_t, 32>;

Bytes random_bytes(std::size_t n);  // from OpenSSL's CSPRNG; throws if it has none
// HKDF-SHA256 of the run secret with `purpose` as its info: one independent key per purpose.
Bytes derive_key(const Bytes& secret, const std::string& purpose, std::size_t len = 32);
Digest hmac_sha256(const Bytes& key, const Bytes& data);
bool same_digest(const std::uint8_t* a, const std::uint8_t* b);  // constant time, 32 bytes

// ---- The relay's handshake (coordinator/relay.h) ----
// Inside LCM's tcpq protocol, on a channel of the relay's own (never forwarded), so that LCM's
// stock client does it: the client subscribes to kRelayAuthChannel; the relay publishes a
// challenge to it (kind 'C', a nonce fresh for this connection); the client publishes its answer
// (kind 'A', a nonce of its own and the HMAC of both under the handshake key); the relay, once the
// answer verifies, publishes its own proof (kind 'K', the HMAC of both nonces in the other
// direction) and from then on forwards to and from the connection. A recorded answer is worth
// nothing on another connection, whose challenge differs.
inline constexpr const char* kRelayAuthChannel = "hemocosim/relay-auth";
inline constexpr std::size_t kNonceBytes = 32;
inline constexpr std::uint8_t kAuthChallenge = 'C', kAuthAnswer = 'A', kAuthAccepted = 'K';
Bytes handshake_key(const Bytes& secret);
// What the client sends: 'A', client nonce, HMAC(key, "client" relay nonce client nonce).
Bytes handshake_answer(const Bytes& key, const Bytes& relay_nonce, const Bytes& client_nonce);
// What the relay sends back: 'K', HMAC(key, "relay" relay nonce client nonce).
Bytes handshake_proof(const Bytes& key, const Bytes& relay_nonce, const Bytes& client_nonce);
// The client nonce of an answer that verifies against the relay's nonce; nothing otherwise.
std::optional<Bytes> check_handshake_answer(const Bytes& key, const Bytes& relay_nonce, const std::uint8_t* answer,
                                            std::size_t len);

// ---- Sealed messages (bus.encrypt) ----
// A sealed message keeps the envelope in the clear, where every receiver checks it before
// anything else, and replaces the LCM type fingerprint and the payload by AES-256-GCM of them:
//   [kSealedMark 8][envelope, tag included][nonce 12][ciphertext of fingerprint + payload][GCM tag 16]
// The HMAC tag is computed over the sealed bytes as over any message, so the checks of bus.h run
// unchanged; the GCM nonce is random (2^-32 collision odds after 2^32 messages of one run).
inline constexpr std::array<std::uint8_t, 8> kSealedMark = {'H', 'C', 'S', 'E', 'A', 'L', 'v', '1'};
inline constexpr std::size_t kSealOverhead = 8 + 12 + 16;  // the mark (the fingerprint moves inside), nonce, GCM tag
Bytes seal_key(const Bytes& secret);
bool is_sealed(const std::uint8_t* buf, std::size_t len);
// `plain` is an encoded message with its envelope ending at `body_offset` (after the tag).
Bytes seal(const Bytes& key, const std::uint8_t* plain, std::size_t len, std::size_t body_offset);
// The encoded message back; nothing when the ciphertext does not open with this key.
std::optional<Bytes> unseal(const Bytes& key, const std::uint8_t* sealed, std::size_t len, std::size_t body_offset);

}  // namespace hemo
