//! The memory bandwidth of GPUs by their specification, for adapters whose name identifies them:
//! the third figure beside the two measured ones (`gpu::profile`), so that a reader sees how near
//! the streaming kernel comes to what the card is sold as (a streaming kernel typically reaches
//! 85–93 % of it on HBM parts).
//!
//! Figures are the vendors' data sheets, in bytes per second (1 TB/s = 10¹² B/s), read + written
//! together as the yardstick counts them (a memory's bandwidth is shared by both directions):
//! - NVIDIA H200 (SXM and NVL, 141 GB HBM3e): 4.8 TB/s, "NVIDIA H200 Tensor Core GPU" data sheet.
//! - NVIDIA GH200 (96 GB HBM3): 4.0 TB/s, "NVIDIA GH200 Grace Hopper Superchip" data sheet.
//! - NVIDIA H100 SXM5 (80 GB HBM3): 3.35 TB/s; H100 NVL (94 GB HBM3): 3.9 TB/s; H100 PCIe
//!   (80 GB HBM2e): 2.0 TB/s, "NVIDIA H100 Tensor Core GPU" data sheet.
//! - NVIDIA A100 80 GB SXM4: 2.039 TB/s; 80 GB PCIe: 1.935 TB/s; 40 GB: 1.555 TB/s, "NVIDIA A100
//!   Tensor Core GPU" data sheet.
//! - NVIDIA V100 (SXM2 and PCIe): 900 GB/s; L40S and L40: 864 GB/s; A10 / A10G: 600 GB/s;
//!   L4: 300 GB/s; T4: 320 GB/s, their data sheets.
//! - GeForce RTX 4090: 1008 GB/s; RTX 3090: 936 GB/s, NVIDIA's product pages.

/// One card: the words its adapter name must hold (as whole words, any case), its bandwidth in
/// bytes per second, and its name as the report writes it. More specific entries come first.
struct Card {
    words: &'static [&'static str],
    bytes_per_s: f64,
    name: &'static str,
}

const CARDS: &[Card] = &[
    Card { words: &["GH200"], bytes_per_s: 4.0e12, name: "NVIDIA GH200 96 GB HBM3" },
    Card { words: &["H200"], bytes_per_s: 4.8e12, name: "NVIDIA H200 141 GB HBM3e" },
    Card { words: &["H100", "PCIe"], bytes_per_s: 2.0e12, name: "NVIDIA H100 PCIe 80 GB HBM2e" },
    Card { words: &["H100", "NVL"], bytes_per_s: 3.9e12, name: "NVIDIA H100 NVL 94 GB HBM3" },
    Card { words: &["H100"], bytes_per_s: 3.35e12, name: "NVIDIA H100 SXM5 80 GB HBM3" },
    Card { words: &["A100", "SXM4", "80GB"], bytes_per_s: 2.039e12, name: "NVIDIA A100 SXM4 80 GB" },
    Card { words: &["A100", "80GB"], bytes_per_s: 1.935e12, name: "NVIDIA A100 PCIe 80 GB" },
    Card { words: &["A100"], bytes_per_s: 1.555e12, name: "NVIDIA A100 40 GB" },
    Card { words: &["V100"], bytes_per_s: 0.9e12, name: "NVIDIA V100" },
    Card { words: &["L40S"], bytes_per_s: 0.864e12, name: "NVIDIA L40S" },
    Card { words: &["L40"], bytes_per_s: 0.864e12, name: "NVIDIA L40" },
    Card { words: &["A10G"], bytes_per_s: 0.6e12, name: "NVIDIA A10G" },
    Card { words: &["A10"], bytes_per_s: 0.6e12, name: "NVIDIA A10" },
    Card { words: &["L4"], bytes_per_s: 0.3e12, name: "NVIDIA L4" },
    Card { words: &["T4"], bytes_per_s: 0.32e12, name: "NVIDIA T4" },
    Card { words: &["RTX", "4090"], bytes_per_s: 1.008e12, name: "NVIDIA GeForce RTX 4090" },
    Card { words: &["RTX", "3090"], bytes_per_s: 0.936e12, name: "NVIDIA GeForce RTX 3090" },
];

/// The specified memory bandwidth (bytes per second) and the card's name, for an adapter name
/// that identifies a card of the table; None for any other (software adapters included).
pub fn spec_bandwidth(adapter: &str) -> Option<(f64, &'static str)> {
    // A GL renderer string names the bus after the card ("NVIDIA H100 80GB HBM3/PCIe/SSE2"):
    // only what comes before the first '/' names the card.
    let card = adapter.split('/').next().unwrap_or("");
    let words: Vec<String> = card.split(|c: char| !c.is_ascii_alphanumeric()).filter(|w| !w.is_empty()).map(|w| w.to_ascii_uppercase()).collect();
    CARDS.iter().find(|c| c.words.iter().all(|w| words.iter().any(|x| x == &w.to_ascii_uppercase()))).map(|c| (c.bytes_per_s, c.name))
}

#[cfg(test)]
mod tests {
    use super::spec_bandwidth;

    #[test]
    fn adapter_names_find_their_card() {
        let bw = |n: &str| spec_bandwidth(n).map(|x| x.0);
        assert_eq!(bw("NVIDIA H100 80GB HBM3"), Some(3.35e12));
        assert_eq!(bw("NVIDIA H100 PCIe"), Some(2.0e12));
        // NVIDIA's GL renderer string of the same SXM card (H100 machine, 2026-11-26).
        assert_eq!(bw("NVIDIA H100 80GB HBM3/PCIe/SSE2"), Some(3.35e12));
        assert_eq!(bw("NVIDIA H100 NVL"), Some(3.9e12));
        assert_eq!(bw("NVIDIA H200"), Some(4.8e12));
        assert_eq!(bw("NVIDIA GH200 480GB"), Some(4.0e12));
        assert_eq!(bw("NVIDIA A100-SXM4-80GB"), Some(2.039e12));
        assert_eq!(bw("NVIDIA A100-PCIE-40GB"), Some(1.555e12));
        assert_eq!(bw("NVIDIA L40S"), Some(0.864e12));
        assert_eq!(bw("NVIDIA L4"), Some(0.3e12));
        // Words, not substrings: an L40 is no L4, an A10G no A10.
        assert_eq!(bw("NVIDIA L40"), Some(0.864e12));
        assert_eq!(bw("NVIDIA A10G"), Some(0.6e12));
        assert_eq!(bw("llvmpipe (LLVM 19.1.7, 256 bits)"), None);
        assert_eq!(bw("lavapipe"), None);
        assert_eq!(bw(""), None);
    }
}
