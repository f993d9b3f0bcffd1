/**
 * @file xpParallel.h
 * @brief A parallel loop over an index range: vtkSMPTools::For in xpose, std::thread where the
 *        kernels are built without VTK (XP_WITHOUT_VTK: the GPU harness of Utilities/GPU).
 *
 * f(begin, end) is called on disjoint chunks that cover [first, last), as vtkSMPTools::For does.
 */
#ifndef xpParallel_h
#define xpParallel_h

#ifndef XP_WITHOUT_VTK
#include <vtkSMPTools.h>
#else
#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>
#endif

namespace xp
{

/** Chunks of about `grain` indices (0: the backend's choice). */
template <typename Index, typename Function>
void ParallelFor(Index first, Index last, Index grain, Function&& f)
{
#ifndef XP_WITHOUT_VTK
  if (grain > 0)
    vtkSMPTools::For(first, last, grain, f);
  else
    vtkSMPTools::For(first, last, f);
#else
  if (last <= first)
    return;
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  const Index count = last - first;
  const Index chunk = grain > 0 ? grain : std::max<Index>(1, count / static_cast<Index>(threads * 4));
  std::atomic<long long> next{ 0 };
  const auto work = [&]()
  {
    for (;;)
    {
      const long long begin = next.fetch_add(static_cast<long long>(chunk));
      if (begin >= static_cast<long long>(count))
        return;
      const Index from = first + static_cast<Index>(begin);
      f(from, std::min<Index>(last, from + chunk));
    }
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t)
    pool.emplace_back(work);
  work();
  for (std::thread& thread : pool)
    thread.join();
#endif
}

template <typename Index, typename Function>
void ParallelFor(Index first, Index last, Function&& f)
{
  ParallelFor(first, last, Index(0), f);
}

} // namespace xp

#endif
