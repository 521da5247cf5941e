//! A node's brick textures kept across frames, as a real cluster keeps the
//! 3D textures it uploaded: [`slice3d::prepare`] (min–max blocks and the
//! tiled copy of the samples, or the pre-classified RGBA8 texture) runs once
//! per brick, not once per brick per frame.
//!
//! An entry is valid while both hold:
//!
//! - the brick's samples are the same allocation (`Arc::ptr_eq` on the
//!   brick's [`Volume`]; the entry holds that `Arc`, so the allocation
//!   cannot be freed and reused by other samples while the entry lives);
//! - the options that shape the texture are equal: the classification
//!   (post, pre-integrated: scalars tiled; pre: RGBA8), and with
//!   pre-classification the transfer function and the scalar range the
//!   texture was classified with.
//!
//! Anything else (the view, the slice planes, ERT, the brick's screen
//! rectangle) is per frame and never cached. A miss replaces the brick's
//! entry, so the cache holds at most one texture per brick id.

use std::sync::Arc;

use crate::data::Volume;
use crate::render::slice3d::{self, Prepared};
use crate::render::slicing::Classify;
use crate::render::VolumeInput;
use crate::scene::TransferFunction;

/// What shapes a brick's prepared texture besides its samples.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureKey {
    /// The classification the texture serves.
    pub classify: Classify,
    /// With pre-classification: the transfer function and scalar range the
    /// RGBA8 texture was classified with (`None` otherwise: scalars do not
    /// depend on them).
    pub classified_by: Option<(TransferFunction, [f64; 2])>,
}

impl TextureKey {
    /// The key of a texture for `classify` under `input`'s transfer function.
    pub fn new(input: &VolumeInput, classify: Classify) -> TextureKey {
        TextureKey {
            classify,
            classified_by: (classify == Classify::Pre)
                .then(|| (input.scene.transfer.clone(), input.range)),
        }
    }
}

struct Entry {
    brick: u32,
    samples: Arc<Volume>,
    key: TextureKey,
    prepared: Arc<Prepared>,
}

/// A node's cached brick textures.
#[derive(Default)]
pub struct BrickTextures {
    entries: Vec<Entry>,
    hits: u64,
    misses: u64,
}

impl BrickTextures {
    /// The prepared texture of brick `brick` (samples `samples`) for `key`,
    /// built from `input` (the brick's own input: its samples, the scene's
    /// transfer function and range) on a miss. Returns it and whether it
    /// was built now.
    pub fn get(
        &mut self,
        brick: u32,
        samples: &Arc<Volume>,
        key: &TextureKey,
        input: &VolumeInput,
    ) -> (Arc<Prepared>, bool) {
        debug_assert!(Arc::ptr_eq(samples, &input.volume));
        if let Some(e) = self
            .entries
            .iter()
            .find(|e| e.brick == brick && Arc::ptr_eq(&e.samples, samples) && e.key == *key)
        {
            self.hits += 1;
            return (e.prepared.clone(), false);
        }
        self.misses += 1;
        let prepared = Arc::new(slice3d::prepare(input, key.classify));
        self.entries.retain(|e| e.brick != brick);
        self.entries.push(Entry {
            brick,
            samples: samples.clone(),
            key: key.clone(),
            prepared: prepared.clone(),
        });
        (prepared, true)
    }

    /// Textures held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether it holds none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Look-ups that found a valid texture, and those that built one.
    pub fn counts(&self) -> (u64, u64) {
        (self.hits, self.misses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::grid::tests::{seam_input, OBLIQUE};

    /// A hit needs the same samples (allocation) and the same shaping
    /// options; the transfer function matters only to pre-classification.
    #[test]
    fn entries_are_invalidated_by_samples_and_shaping_options() {
        let inp = seam_input(OBLIQUE, 16);
        let vol = inp.volume.clone();
        let mut c = BrickTextures::default();
        let post = TextureKey::new(&inp, Classify::Post);
        assert!(c.get(3, &vol, &post, &inp).1, "first look-up builds");
        assert!(!c.get(3, &vol, &post, &inp).1, "then it is kept");
        // The same samples in another allocation: built again.
        let copy = Arc::new((*vol).clone());
        let inp2 = VolumeInput {
            volume: copy.clone(),
            ..inp.clone()
        };
        assert!(c.get(3, &copy, &post, &inp2).1);
        assert_eq!(c.len(), 1, "one texture per brick");
        // Another classification: built again.
        let pre = TextureKey::new(&inp2, Classify::Pre);
        assert!(c.get(3, &copy, &pre, &inp2).1);
        assert!(!c.get(3, &copy, &pre, &inp2).1);
        // Another transfer function: the RGBA8 texture is rebuilt, the
        // scalar one is not.
        let mut inp3 = inp2.clone();
        inp3.scene.transfer.points[1].opacity *= 0.5;
        let pre3 = TextureKey::new(&inp3, Classify::Pre);
        assert_ne!(pre, pre3);
        assert!(c.get(3, &copy, &pre3, &inp3).1);
        assert_eq!(
            TextureKey::new(&inp3, Classify::Post),
            TextureKey::new(&inp2, Classify::Post)
        );
        assert_eq!(c.counts(), (2, 4));
    }
}
