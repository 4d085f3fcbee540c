// Emitters count only the light rays can reach: an emissive surface cut out by alphaMode MASK
// emits nothing where it is cut out, and a BLEND one emits in proportion to its alpha (rays hit
// it with probability alpha). Light sampling uses Emitter::radiance, the mean over the triangle,
// so it has to agree with what the intersector lets rays hit.
#include <gtest/gtest.h>

#include <string>

#include "dofcache/scene/gltf_loader.h"
#include "scene/gltf_builder.h"

namespace dofcache::scene {
namespace {

using test::Gltf;

// Two triangles side by side, each a primitive of its own with material 0 and 1.
Scene load_pair(const std::string& material0, const std::string& material1,
                const std::string& extra_attribute = "") {
  Gltf g;
  const int left = g.add_floats({0, 0, 0, 1, 0, 0, 0, 1, 0}, "VEC3");
  const int right = g.add_floats({2, 0, 0, 3, 0, 0, 2, 1, 0}, "VEC3");
  auto primitive = [&](int pos, int material) {
    return "{\"attributes\":{\"POSITION\":" + std::to_string(pos) + extra_attribute +
           "},\"material\":" + std::to_string(material) + "}";
  };
  return load_gltf_from_memory(
      g.json("\"nodes\":[{\"mesh\":0}],\"meshes\":[{\"primitives\":[" + primitive(left, 0) +
             "," + primitive(right, 1) + "]}],\"materials\":[" + material0 + "," + material1 +
             "]"),
      "emitters.gltf");
}

std::string emissive(const std::string& alpha_mode, float alpha, float cutoff = 0.5f) {
  return "{\"emissiveFactor\":[1,0.5,0.25],\"alphaMode\":\"" + alpha_mode +
         "\",\"alphaCutoff\":" + std::to_string(cutoff) +
         ",\"pbrMetallicRoughness\":{\"baseColorFactor\":[1,1,1," + std::to_string(alpha) +
         "]}}";
}

TEST(EmitterAlpha, MaskCutOutEmittersEmitNothing) {
  // Alpha 0.3 under the cutoff 0.5: the left triangle is not there for any ray, so it is no
  // light either; alpha 0.8 keeps the right one whole, at its full radiance.
  Scene s = load_pair(emissive("MASK", 0.3f), emissive("MASK", 0.8f));
  ASSERT_EQ(s.emitters.size(), 1u);
  EXPECT_EQ(s.emitters[0].triangle, 1u);
  EXPECT_FLOAT_EQ(s.emitters[0].radiance.r, 1.0f);
  EXPECT_FLOAT_EQ(s.emitters[0].radiance.g, 0.5f);
  EXPECT_FLOAT_EQ(s.emitters[0].radiance.b, 0.25f);
}

TEST(EmitterAlpha, BlendEmittersEmitInProportionToAlpha) {
  // Rays hit a BLEND surface with probability alpha: on average it emits alpha times its
  // radiance. An OPAQUE surface ignores its alpha.
  Scene s = load_pair(emissive("BLEND", 0.25f), emissive("OPAQUE", 0.25f));
  ASSERT_EQ(s.emitters.size(), 2u);
  EXPECT_EQ(s.emitters[0].triangle, 0u);
  EXPECT_NEAR(s.emitters[0].radiance.r, 0.25f, 1e-6f);
  EXPECT_NEAR(s.emitters[0].radiance.g, 0.125f, 1e-6f);
  EXPECT_NEAR(s.emitters[0].radiance.b, 0.0625f, 1e-6f);
  EXPECT_FLOAT_EQ(s.emitters[1].radiance.r, 1.0f);
  // The power that chooses between them follows: the BLEND one is picked a fifth of the time.
  EXPECT_NEAR(s.emitter_cdf[0], 0.2f, 1e-5f);
}

}  // namespace
}  // namespace dofcache::scene
