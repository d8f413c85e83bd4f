/* cub::DeviceRadixSort::SortPairs on the CPU (tests/cuda_emu/cuda_runtime.h): a stable sort of the pairs by the
 * keys' bits [begin_bit, end_bit), as CUB's LSD radix sort orders them; with no temporary storage given it only
 * says how much it wants (one byte), as CUB's first call does. */
#ifndef SPRAYCOAT_CUDA_EMU_RADIX_SORT_H
#define SPRAYCOAT_CUDA_EMU_RADIX_SORT_H

#include <algorithm>
#include <numeric>
#include <vector>

#include <cuda_runtime.h>

namespace cub
{
struct DeviceRadixSort {
    template <typename K, typename V>
    static cudaError_t SortPairs(void *temp, size_t &temp_bytes, const K *keys_in, K *keys_out, const V *values_in,
                                 V *values_out, int count, int begin_bit = 0, int end_bit = (int)(sizeof(K) * 8),
                                 cudaStream_t stream = 0)
    {
        (void)stream;
        if (!temp) {
            temp_bytes = 1;
            return cudaSuccess;
        }
        if (count < 0 || begin_bit < 0 || end_bit > (int)(sizeof(K) * 8) || begin_bit > end_bit)
            return cudaErrorInvalidValue;
        int width = end_bit - begin_bit;
        K mask = width >= (int)(sizeof(K) * 8) ? (K) ~(K)0 : (K)(((K)1 << width) - 1);
        auto digits = [&](K key) { return (K)((key >> begin_bit) & mask); };
        std::vector<int> order((size_t)count);
        std::iota(order.begin(), order.end(), 0);
        std::stable_sort(order.begin(), order.end(),
                         [&](int a, int b) { return digits(keys_in[a]) < digits(keys_in[b]); });
        std::vector<K> keys((size_t)count);
        std::vector<V> values((size_t)count);
        for (int i = 0; i < count; i++)
            keys[(size_t)i] = keys_in[order[(size_t)i]], values[(size_t)i] = values_in[order[(size_t)i]];
        std::copy(keys.begin(), keys.end(), keys_out);
        std::copy(values.begin(), values.end(), values_out);
        return cudaSuccess;
    }
};
} // namespace cub

#endif
