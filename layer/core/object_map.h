#pragma once

// Per-object state looked up by handle (the Mesa overlay / vkBasalt pattern).
//
// Lookups take a shared lock only for the hash lookup itself; the returned pointer stays valid
// after the lock is released because Vulkan's external-synchronisation rules forbid using an
// object while another thread destroys it. Each map has its own lock, so no hook holds a global
// lock around a call into the driver.

#include <memory>
#include <mutex>
#include <shared_mutex>
#include <unordered_map>
#include <utility>
#include <vector>

namespace splitvk {

template <typename Key, typename State>
class ObjectMap {
public:
    // Replaces any state `key` had: for a handle the driver has just made (and so may reuse from
    // an object destroyed before), never one another thread may be naming for the first time.
    State *insert(Key key, std::unique_ptr<State> state) {
        std::unique_lock lock(mutex_);
        auto &slot = map_[key];
        slot = std::move(state);
        return slot.get();
    }

    // The state of `key`, made by `make()` under the map's lock if there was none, and whether
    // this call made it. For objects that several threads may name first at once (a queue that
    // vkGetDeviceQueue hands to each): a check then an insert would let two of them make a state
    // each and the second replace the first while another thread holds it.
    template <class Make>
    std::pair<State *, bool> insert_if_absent(Key key, Make &&make) {
        std::unique_lock lock(mutex_);
        auto [it, inserted] = map_.try_emplace(key);
        if (inserted) it->second = make();
        return {it->second.get(), inserted};
    }

    State *find(Key key) const {
        std::shared_lock lock(mutex_);
        const auto it = map_.find(key);
        return it == map_.end() ? nullptr : it->second.get();
    }

    std::unique_ptr<State> remove(Key key) {
        std::unique_lock lock(mutex_);
        const auto it = map_.find(key);
        if (it == map_.end()) return nullptr;
        auto state = std::move(it->second);
        map_.erase(it);
        return state;
    }

    // Every state, removed: what is left at exit.
    std::vector<std::unique_ptr<State>> take_all() {
        std::unique_lock lock(mutex_);
        std::vector<std::unique_ptr<State>> out;
        out.reserve(map_.size());
        for (auto &[key, state] : map_)
            out.push_back(std::move(state));
        map_.clear();
        return out;
    }

private:
    mutable std::shared_mutex mutex_;
    std::unordered_map<Key, std::unique_ptr<State>> map_;
};

} // namespace splitvk
