// 8 identical drones running identical blocks, side by side: each
// chooses a leg by its battery and flies three laps. Their steps commute,
// so the checker's stubborn sets take them one drone after another: the
// markings grow with the fleet, not as its power (symmetry reduction
// would have nothing left to fold).
package Identical

var (
	D1 Quadcopter
	D2 Quadcopter
	D3 Quadcopter
	D4 Quadcopter
	D5 Quadcopter
	D6 Quadcopter
	D7 Quadcopter
	D8 Quadcopter
)

func PAR_All() {
	SEQ_D1()
	SEQ_D2()
	SEQ_D3()
	SEQ_D4()
	SEQ_D5()
	SEQ_D6()
	SEQ_D7()
	SEQ_D8()
}

func SEQ_D1() {
	D1.Arm()
	D1.Takeoff(2)
	If(D1.Battery() > 50, SEQ_Far1, SEQ_Near1)
	RepeatFor(3, SEQ_Lap1)
	D1.Land()
}

func SEQ_Far1() {
	D1.FlyByX(10)
	D1.TakePhoto()
}

func SEQ_Near1() {
	D1.FlyByX(2)
}

func SEQ_Lap1() {
	D1.FlyByY(1)
	D1.TakePhoto()
	D1.FlyByY(-1)
}

func SEQ_D2() {
	D2.Arm()
	D2.Takeoff(2)
	If(D2.Battery() > 50, SEQ_Far2, SEQ_Near2)
	RepeatFor(3, SEQ_Lap2)
	D2.Land()
}

func SEQ_Far2() {
	D2.FlyByX(10)
	D2.TakePhoto()
}

func SEQ_Near2() {
	D2.FlyByX(2)
}

func SEQ_Lap2() {
	D2.FlyByY(1)
	D2.TakePhoto()
	D2.FlyByY(-1)
}

func SEQ_D3() {
	D3.Arm()
	D3.Takeoff(2)
	If(D3.Battery() > 50, SEQ_Far3, SEQ_Near3)
	RepeatFor(3, SEQ_Lap3)
	D3.Land()
}

func SEQ_Far3() {
	D3.FlyByX(10)
	D3.TakePhoto()
}

func SEQ_Near3() {
	D3.FlyByX(2)
}

func SEQ_Lap3() {
	D3.FlyByY(1)
	D3.TakePhoto()
	D3.FlyByY(-1)
}

func SEQ_D4() {
	D4.Arm()
	D4.Takeoff(2)
	If(D4.Battery() > 50, SEQ_Far4, SEQ_Near4)
	RepeatFor(3, SEQ_Lap4)
	D4.Land()
}

func SEQ_Far4() {
	D4.FlyByX(10)
	D4.TakePhoto()
}

func SEQ_Near4() {
	D4.FlyByX(2)
}

func SEQ_Lap4() {
	D4.FlyByY(1)
	D4.TakePhoto()
	D4.FlyByY(-1)
}

func SEQ_D5() {
	D5.Arm()
	D5.Takeoff(2)
	If(D5.Battery() > 50, SEQ_Far5, SEQ_Near5)
	RepeatFor(3, SEQ_Lap5)
	D5.Land()
}

func SEQ_Far5() {
	D5.FlyByX(10)
	D5.TakePhoto()
}

func SEQ_Near5() {
	D5.FlyByX(2)
}

func SEQ_Lap5() {
	D5.FlyByY(1)
	D5.TakePhoto()
	D5.FlyByY(-1)
}

func SEQ_D6() {
	D6.Arm()
	D6.Takeoff(2)
	If(D6.Battery() > 50, SEQ_Far6, SEQ_Near6)
	RepeatFor(3, SEQ_Lap6)
	D6.Land()
}

func SEQ_Far6() {
	D6.FlyByX(10)
	D6.TakePhoto()
}

func SEQ_Near6() {
	D6.FlyByX(2)
}

func SEQ_Lap6() {
	D6.FlyByY(1)
	D6.TakePhoto()
	D6.FlyByY(-1)
}

func SEQ_D7() {
	D7.Arm()
	D7.Takeoff(2)
	If(D7.Battery() > 50, SEQ_Far7, SEQ_Near7)
	RepeatFor(3, SEQ_Lap7)
	D7.Land()
}

func SEQ_Far7() {
	D7.FlyByX(10)
	D7.TakePhoto()
}

func SEQ_Near7() {
	D7.FlyByX(2)
}

func SEQ_Lap7() {
	D7.FlyByY(1)
	D7.TakePhoto()
	D7.FlyByY(-1)
}

func SEQ_D8() {
	D8.Arm()
	D8.Takeoff(2)
	If(D8.Battery() > 50, SEQ_Far8, SEQ_Near8)
	RepeatFor(3, SEQ_Lap8)
	D8.Land()
}

func SEQ_Far8() {
	D8.FlyByX(10)
	D8.TakePhoto()
}

func SEQ_Near8() {
	D8.FlyByX(2)
}

func SEQ_Lap8() {
	D8.FlyByY(1)
	D8.TakePhoto()
	D8.FlyByY(-1)
}
