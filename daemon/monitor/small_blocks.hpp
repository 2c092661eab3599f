#pragma once
// Threading: one per Lua state, used by the daemon's one thread.

#include <array>
#include <cstddef>
#include <cstdlib>

namespace plexus::daemon::monitor {

/// Keeps freed small blocks for reuse. A monitor's script makes and drops a few small objects per
/// message (the decoded payload's table, its strings); taking them from a free list instead of
/// malloc/free saves a good part of a callback's cost. At most `max_kept` blocks per size class
/// are kept, so the cache stays bounded (under 1 MiB) whatever a script did before.
class SmallBlocks {
public:
    static constexpr std::size_t granularity = 16;
    static constexpr std::size_t largest = 256;  ///< larger blocks go straight to malloc

    SmallBlocks() = default;
    SmallBlocks(const SmallBlocks&) = delete;
    SmallBlocks& operator=(const SmallBlocks&) = delete;
    ~SmallBlocks() {
        for (auto& list : free_) {
            while (list.head) {
                Node* next = list.head->next;
                std::free(list.head);
                list.head = next;
            }
        }
    }

    /// A block of at least `size` bytes (size > 0), or null when memory is exhausted.
    void* take(std::size_t size) {
        if (size > largest)
            return std::malloc(size);
        auto& list = free_[index(size)];
        if (list.head) {
            Node* node = list.head;
            list.head = node->next;
            --list.kept;
            return node;
        }
        return std::malloc(class_size(size));
    }

    /// Gives back a block that take(size) returned.
    void give(void* block, std::size_t size) {
        if (size > largest) {
            std::free(block);
            return;
        }
        auto& list = free_[index(size)];
        if (list.kept >= max_kept) {
            std::free(block);
            return;
        }
        auto* node = static_cast<Node*>(block);
        node->next = list.head;
        list.head = node;
        ++list.kept;
    }

    /// True when blocks of these two sizes come from the same class (a resize can stay in place).
    static bool same_class(std::size_t a, std::size_t b) {
        return a <= largest && b <= largest && index(a) == index(b);
    }

private:
    struct Node {
        Node* next;
    };
    struct FreeList {
        Node* head = nullptr;
        std::size_t kept = 0;
    };
    static constexpr std::size_t max_kept = 256;

    static std::size_t index(std::size_t size) { return (size - 1) / granularity; }
    static std::size_t class_size(std::size_t size) { return (index(size) + 1) * granularity; }

    std::array<FreeList, largest / granularity> free_{};
};

}  // namespace plexus::daemon::monitor
