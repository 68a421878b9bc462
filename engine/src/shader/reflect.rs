//! Reflection of one shader stage with spirq: descriptor bindings by name, push-constant size,
//! workgroup size.

use ash::vk;
use spirq::prelude::*;

use super::{ShaderError, Spirv};

/// One descriptor binding a shader declares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindingInfo {
    pub name: String,
    pub set: u32,
    pub binding: u32,
    pub descriptor_type: vk::DescriptorType,
    pub count: u32,
    /// Byte size of a uniform block (`None` for other descriptors).
    pub uniform_size: Option<usize>,
}

/// What a pipeline needs to know about a shader stage.
#[derive(Clone, Debug)]
pub struct Reflection {
    pub shader: String,
    pub stage: vk::ShaderStageFlags,
    pub entry_point: String,
    /// Sorted by (set, binding).
    pub bindings: Vec<BindingInfo>,
    pub push_constant_size: Option<usize>,
    pub workgroup_size: Option<[u32; 3]>,
    /// Specialization constants: (name, constant_id), sorted by id.
    pub spec_constants: Vec<(String, u32)>,
}

fn descriptor_type(t: &DescriptorType) -> vk::DescriptorType {
    match t {
        DescriptorType::Sampler() => vk::DescriptorType::SAMPLER,
        DescriptorType::CombinedImageSampler() => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
        DescriptorType::SampledImage() => vk::DescriptorType::SAMPLED_IMAGE,
        DescriptorType::StorageImage(_) => vk::DescriptorType::STORAGE_IMAGE,
        DescriptorType::UniformTexelBuffer() => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
        DescriptorType::StorageTexelBuffer(_) => vk::DescriptorType::STORAGE_TEXEL_BUFFER,
        DescriptorType::UniformBuffer() => vk::DescriptorType::UNIFORM_BUFFER,
        DescriptorType::StorageBuffer(_) => vk::DescriptorType::STORAGE_BUFFER,
        DescriptorType::InputAttachment(_) => vk::DescriptorType::INPUT_ATTACHMENT,
        DescriptorType::AccelStruct() => vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
    }
}

fn as_u32(c: &ConstantValue) -> Option<u32> {
    match c {
        ConstantValue::U32(x) => Some(*x),
        ConstantValue::S32(x) => u32::try_from(*x).ok(),
        ConstantValue::Typeless(b) if b.len() == 4 => {
            Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        }
        _ => None,
    }
}

impl Reflection {
    /// Reflects the single entry point of `spirv`.
    pub fn new(spirv: &Spirv) -> Result<Reflection, ShaderError> {
        let invalid = |message: String| ShaderError::Invalid {
            shader: spirv.name.clone(),
            message,
        };
        let entry_points = ReflectConfig::new()
            .spv(spirv.words.as_slice())
            .ref_all_rscs(true)
            .combine_img_samplers(true)
            .reflect()
            .map_err(|e| invalid(format!("reflection failed: {e}")))?;
        let [entry] = entry_points.as_slice() else {
            return Err(invalid(format!(
                "expected one entry point, found {}",
                entry_points.len()
            )));
        };
        let stage = match entry.exec_model {
            ExecutionModel::GLCompute => vk::ShaderStageFlags::COMPUTE,
            ExecutionModel::Vertex => vk::ShaderStageFlags::VERTEX,
            ExecutionModel::Fragment => vk::ShaderStageFlags::FRAGMENT,
            other => return Err(invalid(format!("unsupported execution model {other:?}"))),
        };
        let mut bindings = Vec::new();
        let mut push_constant_size = None;
        let mut spec_constants = Vec::new();
        for var in &entry.vars {
            match var {
                Variable::Descriptor {
                    name,
                    desc_bind,
                    desc_ty,
                    nbind,
                    ty,
                } => bindings.push(BindingInfo {
                    name: name.clone().ok_or_else(|| {
                        invalid(format!(
                            "binding {desc_bind} has no name (debug info stripped?)"
                        ))
                    })?,
                    set: desc_bind.set(),
                    binding: desc_bind.bind(),
                    descriptor_type: descriptor_type(desc_ty),
                    count: (*nbind).max(1),
                    uniform_size: matches!(desc_ty, DescriptorType::UniformBuffer())
                        .then(|| ty.nbyte())
                        .flatten(),
                }),
                Variable::PushConstant { ty, .. } => {
                    push_constant_size =
                        Some(ty.nbyte().ok_or_else(|| {
                            invalid("push-constant block of unknown size".into())
                        })?);
                }
                Variable::SpecConstant { name, spec_id, .. } => {
                    spec_constants.push((name.clone().unwrap_or_default(), *spec_id));
                }
                _ => {}
            }
        }
        spec_constants.sort_by_key(|(_, id)| *id);
        bindings.sort_by_key(|b| (b.set, b.binding));
        let workgroup_size = entry
            .exec_modes
            .iter()
            .find(|m| {
                // SPIR-V 1.6 (glslc for Vulkan 1.3) writes LocalSizeId; older targets LocalSize.
                matches!(
                    m.exec_mode,
                    spirq::spirv::ExecutionMode::LocalSize
                        | spirq::spirv::ExecutionMode::LocalSizeId
                )
            })
            .and_then(|m| {
                let v: Vec<u32> = m.operands.iter().filter_map(|c| as_u32(&c.value)).collect();
                <[u32; 3]>::try_from(v).ok()
            });
        Ok(Reflection {
            shader: spirv.name.clone(),
            stage,
            entry_point: entry.name.clone(),
            bindings,
            push_constant_size,
            workgroup_size,
            spec_constants,
        })
    }
}
