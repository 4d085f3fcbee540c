// The content hasher's values identify scenes, sequences and cache files on disk: they are pinned
// here so that no change to the hasher can alter them unnoticed.
#include "dofcache/core/content_hash.h"

#include <gtest/gtest.h>

namespace dofcache {
namespace {

TEST(ContentHasher, SequenceConventionValuesArePinned) {
  ContentHasher h(0x73657175656e6365ULL);  // "sequence"
  h.add(std::string("dofcache sequence 1"));
  h.add(std::uint64_t{42});
  h.add(-3);
  h.add(true);
  h.add(0.25);
  h.add(-0.0f);
  h.add(1.5f);
  EXPECT_EQ(h.value(), 0x035f63dcb57b0528ULL);
}

TEST(ContentHasher, SceneConventionValuesArePinned) {
  ContentHasher h(0x646f6663616368ULL);  // "dofcach"
  h.add(std::uint64_t{42});
  h.add_float32(-0.0f);
  h.add_float32(1.5f);
  h.add(std::string("mat"));
  EXPECT_EQ(h.value(), 0xf6230666e668aeddULL);
}

TEST(ContentHasher, SignedZerosHashAlike) {
  ContentHasher a(1), b(1), c(1), d(1);
  a.add(0.0), b.add(-0.0), c.add_float32(0.0f), d.add_float32(-0.0f);
  EXPECT_EQ(a.value(), b.value());
  EXPECT_EQ(c.value(), d.value());
}

TEST(ContentHasher, AFloatHashesAsTheDoubleItEquals) {
  ContentHasher a(1), b(1);
  a.add(0.1f);
  b.add(static_cast<double>(0.1f));
  EXPECT_EQ(a.value(), b.value());
}

TEST(ContentHasher, OrderAndSeedMatter) {
  ContentHasher a(1), b(1), c(2);
  a.add(1), a.add(2);
  b.add(2), b.add(1);
  c.add(1), c.add(2);
  EXPECT_NE(a.value(), b.value());
  EXPECT_NE(a.value(), c.value());
}

}  // namespace
}  // namespace dofcache
