// Cost of the coupling messages at the paper's mesh (1,536 cells): encode, sign, verify, decode,
// the same sealed (bus.encrypt: AES-256-GCM besides the HMAC), and one exchange over real LCM on
// loopback, in the clear and sealed (publish a fluid state, the peer receives and verifies it,
// answers with a feedback message, the first receives that).
// Run: build/bin/bench_messages   (Google Benchmark; figures in docs/performance.md)
// SPDX-License-Identifier: GPL-3.0-or-later
#include "bus.h"
#include "bus_crypto.h"
#include "test_helpers.h"

#include "cell_fields.h"

#include <hemo/heartbeat_t.hpp>
#include <hemo/resend_request_t.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <thread>

using namespace hemo;

namespace {
constexpr int kPaperCells = 1536;

fluid_state_t make_state(int cells) {
  fluid_state_t s{};
  s.mesh_hash = "0123456789abcdef";
  resize_cells(s, cells);
  std::fill(s.velocity.begin(), s.velocity.end(), 1e-3);
  std::fill(s.velocity_gradient.begin(), s.velocity_gradient.end(), 10.0);
  return s;
}

particle_feedback_t make_feedback(int cells) {
  particle_feedback_t f{};
  f.mesh_hash = "0123456789abcdef";
  resize_cells(f, cells);
  std::fill(f.solid_fraction.begin(), f.solid_fraction.end(), 0.15);
  std::fill(f.source_explicit.begin(), f.source_explicit.end(), 1.0);
  std::fill(f.drag_coefficient.begin(), f.drag_coefficient.end(), 1e6);
  return f;
}

void BM_EncodeSignFluidState(benchmark::State& st) {
  auto ctx = test::make_context("bench");
  auto s = make_state(static_cast<int>(st.range(0)));
  std::vector<std::uint8_t> buf;
  for (auto _ : st) {
    buf.resize(static_cast<std::size_t>(s.getEncodedSize()));
    s.encode(buf.data(), 0, static_cast<int>(buf.size()));
    sign(buf, ctx.secret);
    benchmark::DoNotOptimize(buf.data());
  }
  st.SetBytesProcessed(static_cast<int64_t>(st.iterations() * buf.size()));
}
BENCHMARK(BM_EncodeSignFluidState)->Arg(kPaperCells)->Arg(10000)->Arg(100000);

void BM_VerifyDecodeFluidState(benchmark::State& st) {
  auto ctx = test::make_context("bench");
  auto s = make_state(static_cast<int>(st.range(0)));
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(s.getEncodedSize()));
  s.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, ctx.secret);
  for (auto _ : st) {
    if (!verify(buf, ctx.secret)) st.SkipWithError("tag did not verify");
    fluid_state_t out;
    out.decode(buf.data(), 0, static_cast<int>(buf.size()));
    benchmark::DoNotOptimize(out.velocity.data());
  }
  st.SetBytesProcessed(static_cast<int64_t>(st.iterations() * buf.size()));
}
BENCHMARK(BM_VerifyDecodeFluidState)->Arg(kPaperCells)->Arg(10000)->Arg(100000);

// The same work sealed, as a sealing bus publishes: encode, seal (AES-256-GCM), sign the sealed bytes.
void BM_EncodeSealSignFluidState(benchmark::State& st) {
  auto ctx = test::make_context("bench");
  const auto key = seal_key(ctx.secret);
  auto s = make_state(static_cast<int>(st.range(0)));
  std::vector<std::uint8_t> buf, sealed;
  for (auto _ : st) {
    buf.resize(static_cast<std::size_t>(s.getEncodedSize()));
    s.encode(buf.data(), 0, static_cast<int>(buf.size()));
    sealed = seal(key, buf.data(), buf.size(), tag_offset(buf.data(), buf.size()) + 32);
    sign(sealed, ctx.secret);
    benchmark::DoNotOptimize(sealed.data());
  }
  st.SetBytesProcessed(static_cast<int64_t>(st.iterations() * buf.size()));
}
BENCHMARK(BM_EncodeSealSignFluidState)->Arg(kPaperCells)->Arg(10000)->Arg(100000);

// And as a receiver opens it: verify the tag, open, decode.
void BM_VerifyOpenDecodeFluidState(benchmark::State& st) {
  auto ctx = test::make_context("bench");
  const auto key = seal_key(ctx.secret);
  auto s = make_state(static_cast<int>(st.range(0)));
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(s.getEncodedSize()));
  s.encode(buf.data(), 0, static_cast<int>(buf.size()));
  const std::size_t body = tag_offset(buf.data(), buf.size()) + 32;
  auto sealed = seal(key, buf.data(), buf.size(), body);
  sign(sealed, ctx.secret);
  for (auto _ : st) {
    if (!verify(sealed, ctx.secret)) st.SkipWithError("tag did not verify");
    const auto plain = unseal(key, sealed.data(), sealed.size(), body);
    if (!plain) st.SkipWithError("did not open");
    fluid_state_t out;
    out.decode(plain->data(), 0, static_cast<int>(plain->size()));
    benchmark::DoNotOptimize(out.velocity.data());
  }
  st.SetBytesProcessed(static_cast<int64_t>(st.iterations() * buf.size()));
}
BENCHMARK(BM_VerifyOpenDecodeFluidState)->Arg(kPaperCells)->Arg(10000)->Arg(100000);

// What the bus pays for each of its own echoes since it verifies their tag first (issue #21): in
// a run a process hears of its own only its heartbeats (two a second) and its resend requests,
// messages of this size.
void BM_VerifyHeartbeat(benchmark::State& st) {
  auto ctx = test::make_context("bench");
  heartbeat_t hb{};
  hb.envelope.run_id = ctx.run_id;
  hb.envelope.sender = "particles";
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(hb.getEncodedSize()));
  hb.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, ctx.secret);
  for (auto _ : st)
    if (!verify(buf, ctx.secret)) st.SkipWithError("tag did not verify");
  st.SetBytesProcessed(static_cast<int64_t>(st.iterations() * buf.size()));
}
BENCHMARK(BM_VerifyHeartbeat);

// What a bus pays for a resend request it does not answer, past LCM: the tag check and the
// decode (the part a filter on the raw request's channel could skip), and then the request's
// whole way through Bus (the envelope checks, the replay window, the decode, the lookup among what
// it keeps, the pass-on), heard on loopback. In a busy step of the partitioned 2 x 2 run each
// bus of a rank heard up to 8.7 kB of them (docs/notes/partitioned-exchange.md).
void BM_VerifyDecodeResendRequest(benchmark::State& st) {
  auto ctx = test::make_context("bench");
  resend_request_t req{};
  req.envelope.run_id = ctx.run_id;
  req.envelope.sender = "particles.3";
  req.channel = channel::of_pair(channel::fluid_state, 2, 4, 3, 4);
  req.wanted_step = 1000;
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(req.getEncodedSize()));
  req.encode(buf.data(), 0, static_cast<int>(buf.size()));
  sign(buf, ctx.secret);
  for (auto _ : st) {
    if (!verify(buf, ctx.secret)) st.SkipWithError("tag did not verify");
    resend_request_t out;
    benchmark::DoNotOptimize(out.decode(buf.data(), 0, static_cast<int>(buf.size())));
  }
  st.counters["bytes"] = static_cast<double>(buf.size());
}
BENCHMARK(BM_VerifyDecodeResendRequest);

void BM_HearResendRequestForAnotherChannel(benchmark::State& st) {
  auto ctx = test::make_context("resends");
  Bus asker(ctx, "particles.3", {}), hearer(ctx, "fluid.1", {channel::resend});
  const std::string wanted = channel::of_pair(channel::fluid_state, 2, 4, 3, 4);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let both subscribe
  std::int64_t step = 0;
  for (auto _ : st) {
    st.PauseTiming();
    asker.request_resend(wanted, ++step);
    std::this_thread::sleep_for(std::chrono::microseconds(200));  // in the socket before the clock runs
    st.ResumeTiming();
    int heard = 0;
    while (heard == 0)
      if (hearer.poll(1.0, [&](const Received&) { ++heard; }) == 0) {
        st.SkipWithError("request lost");
        break;
      }
  }
}
BENCHMARK(BM_HearResendRequestForAnotherChannel)->Unit(benchmark::kMicrosecond);

// One coupling exchange over LCM on loopback: fluid state one way, feedback the other, each
// process listening to its node's channels, as in a run; the second argument 1: sealed.
void BM_LoopbackExchange(benchmark::State& st) {
  const int cells = static_cast<int>(st.range(0));
  auto ctx = test::make_context("xchg");
  ctx.encrypt = st.range(1) != 0;
  std::atomic<bool> done{false};
  std::thread peer([&] {
    Bus bus(ctx, "particles", channel::heard_by_particles());
    auto fb = make_feedback(cells);
    while (!done) {
      bus.poll(0.05, [&](const Received& m) {
        if (m.kind == channel::fluid_state) {
          auto s = m.as<fluid_state_t>();
          bus.publish(channel::particle_feedback, fb, m.envelope.step);
        }
      });
    }
  });
  Bus bus(ctx, "fluid", channel::heard_by_fluid());
  auto s = make_state(cells);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let the peer subscribe
  std::int64_t step = 0;
  for (auto _ : st) {
    bus.publish(channel::fluid_state, s, ++step);
    bool got = false;
    while (!got) {
      bus.poll(1.0, [&](const Received& m) {
        if (m.kind == channel::particle_feedback && m.envelope.step == step) {
          benchmark::DoNotOptimize(m.as<particle_feedback_t>());
          got = true;
        }
      });
      if (!got) {
        st.SkipWithError("exchange lost");
        break;
      }
    }
  }
  done = true;
  peer.join();
}
BENCHMARK(BM_LoopbackExchange)
    ->ArgsProduct({{kPaperCells, 10000}, {0, 1}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
}  // namespace

BENCHMARK_MAIN();
