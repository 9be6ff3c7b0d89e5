//! One definition for every struct and constant the host and the kernels
//! share. Each is written once, in Rust, through [`device_struct!`] and
//! [`device_consts!`]; from that definition come
//! - the `#[repr(C)]` Rust struct and the `pub const`s;
//! - the C typedefs and `#define`s of `kernels/generated/*.h`
//!   ([`header_text`]; `tests/device_structs.rs` regenerates them and fails
//!   on any difference, and `SOUPRAY_REGENERATE=1` rewrites them);
//! - a layout probe kernel covering every field of every struct
//!   ([`probe_source`]), whose sizes and offsets the same test compares
//!   with Rust's on the OpenCL device.
//!
//! The headers themselves are listed in `kernels::GENERATED_HEADERS`
//! (src/kernels.rs), beside the stages whose structs they hold.

use std::fmt::Write;

/// A Rust field type's C spelling: the scalar base type and the array
/// dimensions, outermost first (`[[f32; 4]; 3]`: `float`, `[3, 4]`).
pub trait CType {
    fn c_base() -> &'static str;
    fn c_dims() -> Vec<usize> {
        Vec::new()
    }
}

macro_rules! scalar_c_type {
    ($($rust:ty => $c:literal),*) => {
        $(impl CType for $rust {
            fn c_base() -> &'static str {
                $c
            }
        })*
    };
}
scalar_c_type!(f32 => "float", u32 => "uint", i32 => "int", u16 => "ushort", u8 => "uchar", u64 => "ulong");

impl<T: CType, const N: usize> CType for [T; N] {
    fn c_base() -> &'static str {
        T::c_base()
    }
    fn c_dims() -> Vec<usize> {
        let mut d = vec![N];
        d.extend(T::c_dims());
        d
    }
}

/// One field as Rust laid it out, and how C declares it.
#[derive(Clone, Debug)]
pub struct FieldLayout {
    pub name: &'static str,
    /// The C base type: a scalar (`float`), or an OpenCL vector (`float4`)
    /// standing for the Rust type's innermost array.
    pub c_base: &'static str,
    /// The C array dimensions, outermost first.
    pub c_dims: Vec<usize>,
    pub offset: usize,
    pub size: usize,
    /// The field's doc comment, one entry per line.
    pub doc: Vec<&'static str>,
}

/// One shared struct as Rust laid it out.
#[derive(Clone, Debug)]
pub struct StructLayout {
    pub rust_name: &'static str,
    pub c_name: &'static str,
    /// The file that defines it, for the generated header's comments.
    pub defined_in: &'static str,
    pub doc: Vec<&'static str>,
    pub size: usize,
    pub fields: Vec<FieldLayout>,
}

/// A struct shared with the kernels, defined by [`device_struct!`].
pub trait DeviceStruct {
    fn layout() -> StructLayout;
}

/// One shared constant, defined by [`device_consts!`].
#[derive(Clone, Debug)]
pub struct ConstDef {
    pub name: std::borrow::Cow<'static, str>,
    pub value: u32,
    pub doc: Vec<&'static str>,
}

/// The C base type and dimensions of a field whose Rust type is `base` and
/// `dims`, declared in C as `c_override` where given: an OpenCL vector type
/// (`float4`, `uint2`) replaces the Rust type's innermost array, whose
/// length must be the vector's.
pub fn c_spelling(
    rust_base: &'static str,
    mut dims: Vec<usize>,
    c_override: Option<&'static str>,
    field: &str,
) -> (&'static str, Vec<usize>) {
    let Some(c) = c_override else {
        return (rust_base, dims);
    };
    let width: usize = c
        .trim_start_matches(|ch: char| ch.is_ascii_alphabetic())
        .parse()
        .unwrap_or(1);
    if width > 1 {
        assert_eq!(
            dims.pop(),
            Some(width),
            "field {field}: {c} must stand for an innermost array of {width}"
        );
    }
    (c, dims)
}

/// Defines a `#[repr(C)]` struct shared with the kernels, and its
/// [`DeviceStruct`] layout. The struct's docs come first, then its `repr`
/// and `derive`, then `pub struct RustName as "CName"`; each field may end
/// in `as "float4"` where C declares an OpenCL vector for it.
macro_rules! device_struct {
    (
        $(#[doc = $doc:literal])*
        #[repr($($repr:tt)*)]
        #[derive($($derive:path),* $(,)?)]
        pub struct $name:ident as $c_name:literal {
            $(
                $(#[doc = $fdoc:literal])*
                pub $field:ident : $ty:ty $(as $c_ty:literal)?
            ),* $(,)?
        }
    ) => {
        $(#[doc = $doc])*
        #[repr($($repr)*)]
        #[derive($($derive),*)]
        pub struct $name {
            $($(#[doc = $fdoc])* pub $field: $ty,)*
        }

        impl $crate::device_struct::DeviceStruct for $name {
            fn layout() -> $crate::device_struct::StructLayout {
                use $crate::device_struct::{c_spelling, CType, FieldLayout, StructLayout};
                StructLayout {
                    rust_name: stringify!($name),
                    c_name: $c_name,
                    defined_in: file!(),
                    doc: vec![$($doc),*],
                    size: std::mem::size_of::<$name>(),
                    fields: vec![$({
                        let over: Option<&'static str> = None $(.or(Some($c_ty)))?;
                        let (c_base, c_dims) = c_spelling(
                            <$ty as CType>::c_base(),
                            <$ty as CType>::c_dims(),
                            over,
                            stringify!($field),
                        );
                        FieldLayout {
                            name: stringify!($field),
                            c_base,
                            c_dims,
                            offset: std::mem::offset_of!($name, $field),
                            size: std::mem::size_of::<$ty>(),
                            doc: vec![$($fdoc),*],
                        }
                    }),*],
                }
            }
        }
    };
}
pub(crate) use device_struct;

/// Defines `pub const NAME: u32` values shared with the kernels, and a
/// function listing them for the generated header's `#define`s.
macro_rules! device_consts {
    (
        fn $list:ident;
        $(
            $(#[doc = $doc:literal])*
            pub const $name:ident : u32 = $value:expr;
        )*
    ) => {
        $($(#[doc = $doc])* pub const $name: u32 = $value;)*

        /// The constants above, for the generated kernel header.
        pub fn $list() -> Vec<$crate::device_struct::ConstDef> {
            vec![$($crate::device_struct::ConstDef {
                name: stringify!($name).into(),
                value: $name,
                doc: vec![$($doc),*],
            }),*]
        }
    };
}
pub(crate) use device_consts;

/// One generated header: its file name under `kernels/generated/`, what it
/// holds, its constants and its structs (in declaration order: a struct
/// may use only those before it).
pub struct GeneratedHeader {
    pub file: &'static str,
    pub about: &'static str,
    pub consts: Vec<ConstDef>,
    pub structs: Vec<StructLayout>,
    /// Generated C after the structs (kernel-only types and functions
    /// made from Rust tables); empty for most headers.
    pub code: String,
}

fn comment(out: &mut String, indent: &str, lines: &[&str]) {
    for line in lines {
        let line = line.strip_prefix(' ').unwrap_or(line);
        if line.is_empty() {
            let _ = writeln!(out, "{indent}//");
        } else {
            let _ = writeln!(out, "{indent}// {line}");
        }
    }
}

/// The text of `kernels/generated/<h.file>`.
pub fn header_text(h: &GeneratedHeader) -> String {
    let guard = format!(
        "SOUPRAY_GENERATED_{}",
        h.file.to_ascii_uppercase().replace(['.', '/', '-'], "_")
    );
    let mut s = String::new();
    let _ = writeln!(
        s,
        "// Generated from the Rust definitions by soupray::device_struct\n\
         // (SOUPRAY_REGENERATE=1 cargo test --test device_structs). Do not edit:\n\
         // change the Rust definition named above each item.\n//"
    );
    comment(&mut s, "", &[h.about]);
    let _ = writeln!(
        s,
        "#ifndef {guard}\n#define {guard}\n\n#pragma OPENCL FP_CONTRACT OFF\n"
    );
    for c in &h.consts {
        comment(&mut s, "", &c.doc);
        let _ = writeln!(s, "#define {} {}u", c.name, c.value);
    }
    if !h.consts.is_empty() {
        s.push('\n');
    }
    for st in &h.structs {
        comment(&mut s, "", &st.doc);
        let _ = writeln!(
            s,
            "// `{}` in {} ({} bytes).",
            st.rust_name, st.defined_in, st.size
        );
        s.push_str("typedef struct {\n");
        for f in &st.fields {
            comment(&mut s, "    ", &f.doc);
            let dims: String = f.c_dims.iter().map(|d| format!("[{d}]")).collect();
            let _ = writeln!(s, "    {} {}{};", f.c_base, f.name, dims);
        }
        let _ = writeln!(s, "}} {};\n", st.c_name);
    }
    s.push_str(&h.code);
    s.push_str("#endif\n");
    s
}

/// A kernel, `struct_layout_probe(out)`, that writes for every struct of
/// `headers` its size and then each field's offset and size, as
/// [`host_layout`] lists them.
pub fn probe_source(headers: &[GeneratedHeader]) -> String {
    let mut s =
        String::from("#ifndef offsetof\n#define offsetof(T, f) __builtin_offsetof(T, f)\n#endif\n");
    for h in headers {
        let _ = writeln!(s, "#include \"{}\"", h.file);
    }
    s.push_str("__kernel void struct_layout_probe(__global uint* out) {\n    uint n = 0;\n");
    for st in headers.iter().flat_map(|h| &h.structs) {
        let t = st.c_name;
        let _ = writeln!(s, "    out[n++] = (uint)sizeof({t});");
        for f in &st.fields {
            let _ = writeln!(
                s,
                "    out[n++] = (uint)offsetof({t}, {0}); out[n++] = (uint)sizeof((({t}*)0)->{0});",
                f.name
            );
        }
    }
    for (t, _) in VECTOR_SIZES {
        let _ = writeln!(s, "    out[n++] = (uint)sizeof({t});");
    }
    s.push_str("}\n");
    s
}

/// OpenCL vector types that buffers share with Rust arrays (`[f32; 2]` as
/// `float2`), and the sizes Rust gives those arrays; the probe checks them
/// after the structs.
pub const VECTOR_SIZES: [(&str, u32); 4] =
    [("float2", 8), ("float4", 16), ("uint2", 8), ("uint4", 16)];

/// The values [`probe_source`]'s kernel writes, from Rust's layouts, with
/// what each one is (`PtFrame.flags offset`), for messages.
pub fn host_layout(headers: &[GeneratedHeader]) -> Vec<(String, u32)> {
    let mut v = Vec::new();
    for st in headers.iter().flat_map(|h| &h.structs) {
        v.push((format!("sizeof({})", st.c_name), st.size as u32));
        for f in &st.fields {
            v.push((format!("{}.{} offset", st.c_name, f.name), f.offset as u32));
            v.push((format!("{}.{} size", st.c_name, f.name), f.size as u32));
        }
    }
    for (t, size) in VECTOR_SIZES {
        v.push((format!("sizeof({t})"), size));
    }
    v
}
