/* cub::DeviceReduce::Sum, Max and Min on the CPU (tests/cuda_emu/cuda_runtime.h).  The sum is taken pairwise (a
 * tree, as a device reduction is, though not CUB's own tree: the bits of a sum may differ from a device's in the
 * last places).  Over no items: 0, the type's lowest and its largest value, as CUB's identities. */
#ifndef SPRAYCOAT_CUDA_EMU_REDUCE_H
#define SPRAYCOAT_CUDA_EMU_REDUCE_H

#include <iterator>
#include <limits>

#include <cuda_runtime.h>

namespace cub
{
struct DeviceReduce {
    template <typename In, typename Out>
    static cudaError_t Sum(void *temp, size_t &temp_bytes, In in, Out out, int count, cudaStream_t stream = 0)
    {
        (void)stream;
        if (!temp) {
            temp_bytes = 1;
            return cudaSuccess;
        }
        *out = pairwise(in, 0, count);
        return cudaSuccess;
    }
    template <typename In, typename Out>
    static cudaError_t Max(void *temp, size_t &temp_bytes, In in, Out out, int count, cudaStream_t stream = 0)
    {
        using T = typename std::iterator_traits<In>::value_type;
        return extreme(temp, temp_bytes, in, out, count, stream, std::numeric_limits<T>::lowest(),
                       [](T a, T b) { return a > b; });
    }
    template <typename In, typename Out>
    static cudaError_t Min(void *temp, size_t &temp_bytes, In in, Out out, int count, cudaStream_t stream = 0)
    {
        using T = typename std::iterator_traits<In>::value_type;
        return extreme(temp, temp_bytes, in, out, count, stream, std::numeric_limits<T>::max(),
                       [](T a, T b) { return a < b; });
    }

  private:
    /* the item `better` than every other, starting from `first` (the identity) */
    template <typename In, typename Out, typename T, typename Better>
    static cudaError_t extreme(void *temp, size_t &temp_bytes, In in, Out out, int count, cudaStream_t stream, T first,
                               Better better)
    {
        (void)stream;
        if (!temp) {
            temp_bytes = 1;
            return cudaSuccess;
        }
        T best = first;
        for (int i = 0; i < count; i++)
            best = better(in[i], best) ? in[i] : best;
        *out = best;
        return cudaSuccess;
    }
    template <typename In> static typename std::iterator_traits<In>::value_type pairwise(In in, int from, int to)
    {
        using T = typename std::iterator_traits<In>::value_type;
        if (to - from <= 8) {
            T sum = T();
            for (int i = from; i < to; i++)
                sum += in[i];
            return sum;
        }
        int middle = from + (to - from) / 2;
        return pairwise(in, from, middle) + pairwise(in, middle, to);
    }
};
} // namespace cub

#endif
