#include "thread_shares.h"

#include <algorithm>
#include <limits>

namespace ctcal {

namespace {

// Breadth-first from `root` over the blocks reachable through common readers; appends them to
// `order` and marks them (blocks and readers) with `stamp`.
void Reach(int root, const std::vector<std::vector<int>>& nuisance_of,
           const std::vector<std::size_t>& first_reader, const std::vector<std::size_t>& readers,
           int stamp, std::vector<int>* block_stamp, std::vector<int>* reader_stamp,
           std::vector<int>* order) {
  const std::size_t begin = order->size();
  order->push_back(root);
  (*block_stamp)[static_cast<std::size_t>(root)] = stamp;
  for (std::size_t q = begin; q < order->size(); ++q) {
    const auto b = static_cast<std::size_t>((*order)[q]);
    for (std::size_t k = first_reader[b]; k < first_reader[b + 1]; ++k) {
      const std::size_t i = readers[k];
      if ((*reader_stamp)[i] == stamp)
        continue;
      (*reader_stamp)[i] = stamp;
      for (const int c : nuisance_of[i]) {
        if ((*block_stamp)[static_cast<std::size_t>(c)] == stamp)
          continue;
        (*block_stamp)[static_cast<std::size_t>(c)] = stamp;
        order->push_back(c);
      }
    }
  }
}

}  // namespace

std::vector<int> BandOrder(const std::vector<std::vector<int>>& nuisance_of, int nuisance_blocks) {
  const auto nb = static_cast<std::size_t>(std::max(nuisance_blocks, 0));
  // The readers of each block, in compressed rows, in the residual blocks' order.
  std::vector<std::size_t> first_reader(nb + 1, 0);
  for (const std::vector<int>& of : nuisance_of)
    for (const int b : of)
      ++first_reader[static_cast<std::size_t>(b) + 1];
  for (std::size_t b = 0; b < nb; ++b)
    first_reader[b + 1] += first_reader[b];
  std::vector<std::size_t> readers(first_reader[nb]);
  {
    std::vector<std::size_t> fill(first_reader.begin(), first_reader.end() - 1);
    for (std::size_t i = 0; i < nuisance_of.size(); ++i)
      for (const int b : nuisance_of[i])
        readers[fill[static_cast<std::size_t>(b)]++] = i;
  }
  // Stamps: 2 k + 1 for component k's probe from its first block, 2 k + 2 for its final pass.
  std::vector<int> block_stamp(nb, 0), reader_stamp(nuisance_of.size(), 0), order, probe;
  order.reserve(nb);
  int component = 0;
  for (std::size_t root = 0; root < nb; ++root) {
    if (block_stamp[root] != 0 || first_reader[root] == first_reader[root + 1])
      continue;
    // The block reached last from the component's first one lies at one end of the band: the
    // order from there runs along it (George and Liu's pseudo-peripheral node, one sweep).
    probe.clear();
    Reach(static_cast<int>(root), nuisance_of, first_reader, readers, 2 * component + 1,
          &block_stamp, &reader_stamp, &probe);
    Reach(probe.back(), nuisance_of, first_reader, readers, 2 * component + 2, &block_stamp,
          &reader_stamp, &order);
    ++component;
  }
  for (std::size_t b = 0; b < nb; ++b)
    if (first_reader[b] == first_reader[b + 1])
      order.push_back(static_cast<int>(b));
  std::vector<int> rank(nb, 0);
  for (std::size_t r = 0; r < order.size(); ++r)
    rank[static_cast<std::size_t>(order[r])] = static_cast<int>(r);
  return rank;
}

ThreadShares ShareBlocks(const std::vector<std::vector<int>>& nuisance_of,
                         const std::vector<double>& work, int nuisance_blocks, int threads) {
  const auto T = static_cast<std::size_t>(std::max(threads, 1));
  const auto nb = static_cast<std::size_t>(std::max(nuisance_blocks, 0));
  ThreadShares shares;
  shares.own.assign(T, {});
  shares.rank = BandOrder(nuisance_of, nuisance_blocks);
  constexpr int kNone = std::numeric_limits<int>::max();
  const std::size_t n = nuisance_of.size();
  std::vector<int> key(n, kNone);
  for (std::size_t i = 0; i < n; ++i)
    for (const int b : nuisance_of[i])
      key[i] = std::min(key[i], shares.rank[static_cast<std::size_t>(b)]);
  std::vector<int> position(nb, kNone);
  for (std::size_t i = 0; i < n; ++i)
    for (const int b : nuisance_of[i])
      position[static_cast<std::size_t>(b)] =
          std::min(position[static_cast<std::size_t>(b)], key[i]);
  // Work per key, then the cuts: cut[t] is the first key of thread t's range.
  std::vector<double> work_at(nb + 1, 0.0);
  double total = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    work_at[key[i] == kNone ? nb : static_cast<std::size_t>(key[i])] += work[i];
    total += work[i];
  }
  std::vector<int> cut(T + 1, 0);
  cut[T] = kNone;
  double sum = 0.0;
  std::size_t t = 1;
  for (std::size_t k = 0; k < nb && t < T; ++k) {
    sum += work_at[k];
    while (t < T && sum >= total * static_cast<double>(t) / static_cast<double>(T))
      cut[t++] = static_cast<int>(k) + 1;
  }
  for (; t < T; ++t)
    cut[t] = static_cast<int>(nb);
  for (std::size_t i = 0; i < n; ++i) {
    if (key[i] == kNone) {  // no nuisance block: H_cc and g_c only, the thread's own
      shares.own[i % T].push_back(i);
      continue;
    }
    int lo = kNone, hi = 0;
    for (const int b : nuisance_of[i]) {
      lo = std::min(lo, position[static_cast<std::size_t>(b)]);
      hi = std::max(hi, position[static_cast<std::size_t>(b)]);
    }
    const auto range =
        static_cast<std::size_t>(std::upper_bound(cut.begin(), cut.end(), lo) - cut.begin() - 1);
    if (hi < cut[range + 1])
      shares.own[range].push_back(i);
    else
      shares.shared.push_back(i);
  }
  return shares;
}

}  // namespace ctcal
