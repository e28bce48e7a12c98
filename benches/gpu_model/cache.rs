//! A set-associative LRU cache of 32-byte sectors: each SM's L1 and the shared L2.

pub const SECTOR: u64 = 32;
const WAYS: usize = 16;
const EMPTY: u64 = u64::MAX;

pub struct Cache {
    sets: usize,
    /// Each set's tags, most recently used first.
    tags: Vec<u64>,
}

impl Cache {
    pub fn new(bytes: u64) -> Cache {
        let sets = ((bytes / SECTOR) as usize / WAYS).max(1);
        Cache {
            sets,
            tags: vec![EMPTY; sets * WAYS],
        }
    }

    /// Whether `sector` is held; it is afterwards, most recently used.
    pub fn access(&mut self, sector: u64) -> bool {
        // Sectors of one 128-byte line share a set; lines spread over the sets by a hash.
        let line = sector >> 2;
        let set = (line.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20) as usize % self.sets;
        let ways = &mut self.tags[set * WAYS..(set + 1) * WAYS];
        let at = ways.iter().position(|&t| t == sector);
        let end = at.unwrap_or(WAYS - 1);
        ways.copy_within(0..end, 1);
        ways[0] = sector;
        at.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_working_set_within_the_cache_hits_and_one_beyond_it_misses() {
        let mut cache = Cache::new(64 << 10);
        let sectors = (64 << 10) / SECTOR / 2;
        (0..sectors).for_each(|s| assert!(!cache.access(s)));
        assert!((0..sectors).all(|s| cache.access(s)));
        let mut big = Cache::new(64 << 10);
        let many = 4 * (64 << 10) / SECTOR;
        (0..many).for_each(|s| _ = big.access(s));
        assert!((0..many).filter(|&s| big.access(s)).count() < many as usize / 4);
    }
}
