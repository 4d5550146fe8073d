//! Typed element handles (`u32` newtypes) and typed per-element attribute
//! maps indexed by them.

use std::marker::PhantomData;
use std::ops::{Index, IndexMut};

/// Common behaviour of the four handle types.
pub trait Handle: Copy + Eq + Ord + std::fmt::Debug {
    /// Builds a handle from an index.
    fn new(i: usize) -> Self;
    /// The index behind the handle.
    fn idx(self) -> usize;
}

macro_rules! handle {
    ($(#[$doc:meta])* $name:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Debug, Default)]
        pub struct $name(pub u32);

        impl $name {
            /// The "no element" value.
            pub const INVALID: Self = Self(u32::MAX);
            /// Whether this is not [`Self::INVALID`].
            #[inline]
            pub fn is_valid(self) -> bool {
                self.0 != u32::MAX
            }
        }

        impl Handle for $name {
            #[inline]
            fn new(i: usize) -> Self {
                debug_assert!(i < u32::MAX as usize);
                Self(i as u32)
            }
            #[inline]
            fn idx(self) -> usize {
                self.0 as usize
            }
        }
    };
}

handle!(
    /// A vertex of a [`super::Mesh`].
    VertexId
);
handle!(
    /// A directed half-edge. Half-edges come in pairs: the twin of `h` is `h ^ 1`.
    HalfedgeId
);
handle!(
    /// An undirected edge: the pair of half-edges `2e` and `2e + 1`.
    EdgeId
);
handle!(
    /// A triangular face.
    FaceId
);

impl HalfedgeId {
    /// The opposite half-edge of the same edge.
    #[inline]
    pub fn twin(self) -> Self {
        Self(self.0 ^ 1)
    }
    /// The undirected edge this half-edge belongs to.
    #[inline]
    pub fn edge(self) -> EdgeId {
        EdgeId(self.0 >> 1)
    }
}

impl EdgeId {
    /// Half-edge `i` (0 or 1) of this edge.
    #[inline]
    pub fn halfedge(self, i: u32) -> HalfedgeId {
        HalfedgeId((self.0 << 1) | (i & 1))
    }
}

/// A typed per-element attribute: one value of `T` per element of kind `H`.
///
/// The mesh keeps its own attributes (face labels, edge flags) up to date
/// through every operator and through compaction. Callers can keep their own
/// maps: grow them with [`Attr::resize`] after operators add elements, and
/// carry them through [`super::Mesh::compact`] with [`Attr::remap`].
#[derive(Clone, Debug)]
pub struct Attr<H, T> {
    data: Vec<T>,
    default: T,
    _kind: PhantomData<H>,
}

/// A per-vertex attribute.
pub type VertexMap<T> = Attr<VertexId, T>;
/// A per-edge attribute.
pub type EdgeMap<T> = Attr<EdgeId, T>;
/// A per-face attribute.
pub type FaceMap<T> = Attr<FaceId, T>;

impl<H: Handle, T: Clone> Attr<H, T> {
    /// A map of `len` elements, all set to `default`; new elements also get `default`.
    pub fn new(len: usize, default: T) -> Self {
        Self {
            data: vec![default.clone(); len],
            default,
            _kind: PhantomData,
        }
    }

    /// A map from existing values; new elements get `default`.
    pub fn from_vec(data: Vec<T>, default: T) -> Self {
        Self {
            data,
            default,
            _kind: PhantomData,
        }
    }

    /// Grows (with the default value) or shrinks the map to `len` elements.
    pub fn resize(&mut self, len: usize) {
        self.data.resize(len, self.default.clone());
    }

    /// Appends a value for a newly created element and returns its handle.
    pub fn push(&mut self, value: T) -> H {
        self.data.push(value);
        H::new(self.data.len() - 1)
    }

    /// Number of elements covered.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// Whether the map covers no element.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The values as a slice indexed by handle index.
    pub fn as_slice(&self) -> &[T] {
        &self.data
    }

    /// The values as a mutable slice indexed by handle index.
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Applies a compaction remap: `new_of_old[i]` is the new index of old
    /// element `i`, or `u32::MAX` when it was removed. The new indices must
    /// be `0..n` for the `n` kept elements, in any order.
    pub fn remap(&mut self, new_of_old: &[u32]) {
        let n = new_of_old.iter().filter(|&&j| j != u32::MAX).count();
        let mut data = vec![self.default.clone(); n];
        for (old, value) in self.data.drain(..).enumerate() {
            let j = new_of_old.get(old).copied().unwrap_or(u32::MAX);
            if j != u32::MAX {
                data[j as usize] = value;
            }
        }
        self.data = data;
    }
}

impl<H, T: Default> Default for Attr<H, T> {
    fn default() -> Self {
        Self {
            data: Vec::new(),
            default: T::default(),
            _kind: PhantomData,
        }
    }
}

impl<H: Handle, T> Index<H> for Attr<H, T> {
    type Output = T;
    #[inline]
    fn index(&self, h: H) -> &T {
        &self.data[h.idx()]
    }
}

impl<H: Handle, T> IndexMut<H> for Attr<H, T> {
    #[inline]
    fn index_mut(&mut self, h: H) -> &mut T {
        &mut self.data[h.idx()]
    }
}
